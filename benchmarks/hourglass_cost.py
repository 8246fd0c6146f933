"""What the hourglass control's frame and the thickness integration cost per increment.

Runs the explicit solver with hourglass-controlled integrations on two scenes, this
revision against an earlier checkout (``--before``), alternated (before, after, before,
after, ...) so that a drift of the machine's speed falls on both alike:

- the crushable-foam core of ``benchmarks/explicit_speed.py`` (``core_compression``, 8 x
  8 x 6, to 60%), the scene of the issue's 2 us target;
- the 12 x 12 x 3 hemisphere with holder (its core bends and turns over the die).

Each row: microseconds per element and increment (``timing.us_per_element_increment``,
the time integration alone), the increments, and the run's headline answer (the
largest punch force, the peak stress), so that a change of the answer is seen next to a
change of the cost. One
untimed short run per revision first fills the compiled-kernel cache. Writes
docs/performance.md's ``hourglass_cost`` section.

Run alone: ``python benchmarks/hourglass_cost.py --before /path/to/checkout`` (about 10
minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _report import REPO, machine, revision, run_case_process, update_section

SCENES = (
    ("crushable-foam core, 8 x 8 x 6", "core_compression",
     ("cells=8,8,6", "strain=0.6", "explicit.loading_time=0.02")),
    ("hemisphere with holder, 12 x 12 x 3", "hemisphere",
     ("blank_holder=true", "cells=12,12,3")),
)


def _answer(summary: dict) -> str:
    """The run's headline answer: the largest punch force, or the peak stress."""
    m = summary["metrics"]
    for key in ("punch_force_max_N", "peak_stress_MPa"):
        if key in m:
            return f"{key} {float(m[key]):.6g}"
    return "-"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--before", type=Path, required=True,
                        help="a checkout of the revision to compare with")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    trees = (("before", args.before), ("after", REPO))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, tree in trees:  # fill the kernel caches
            run_case_process("core_compression", tmp / f"warm_{name}", 1, repo=tree,
                             allow_failure=True,
                             sets=("solver=explicit", "cells=2,2,2", "strain=0.01",
                                   "explicit.loading_time=0.002",
                                   "explicit.integration=reduced"))
        for label, case, sets in SCENES:
            for kind in ("reduced", "thickness"):
                for i in range(args.repeat):
                    for name, tree in trees:
                        if kind == "thickness" and name == "before" and not _has_thickness(
                                tree):
                            continue
                        out = tmp / f"{case}_{kind}_{name}_{i}"
                        s = run_case_process(case, out, 1, repo=tree, allow_failure=True,
                                             sets=("solver=explicit", *sets,
                                                   f"explicit.integration={kind}"))
                        t = s["timing"]
                        rows.append({"scene": label, "integration": kind, "tree": name,
                                     "revision": revision(tree), "status": s["status"],
                                     "increments": t.get("time_steps", t.get("work")),
                                     "us": t.get("us_per_element_increment",
                                                 float("nan")),
                                     "answer": _answer(s)})
                        print(rows[-1], flush=True)
    _report(rows)


def _has_thickness(tree: Path) -> bool:
    text = (tree / "forming" / "solver" / "options.py").read_text()
    return '"thickness"' in text


def _report(rows: list[dict]) -> None:
    lines = [
        "## The hourglass control's cost: before and after", "",
        f"`python benchmarks/hourglass_cost.py --before <checkout>` on {machine()}, alone; "
        "serial, the two revisions' runs alternated. us: the time integration's wall time "
        "per element and increment (`timing.us_per_element_increment`). Answer: the largest "
        "punch force, or the peak stress of the compression.", "",
        "| scene | integration | revision | status | increments | us / element / increment "
        "| answer |",
        "|---|---|---|---|---:|---:|---|",
    ]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['integration']} | {r['revision']} | {r['status']} "
                     f"| {r['increments']} | {r['us']:.3f} | {r['answer']} |")
    lines.append("")
    for label, *_ in SCENES:
        for kind in ("reduced", "thickness"):
            sel = [r for r in rows if r["scene"] == label and r["integration"] == kind]
            before = [r["us"] for r in sel if r["tree"] == "before"]
            after = [r["us"] for r in sel if r["tree"] == "after"]
            if before and after:
                lines.append(f"- {label}, {kind}: {min(after):.3f} us against "
                             f"{min(before):.3f} before (best of each; ratio "
                             f"{min(after) / min(before):.2f}).")
            elif after:
                lines.append(f"- {label}, {kind}: {min(after):.3f} us (best; no such "
                             "integration before).")
    update_section("hourglass_cost", "\n".join(lines), REPO / "docs" / "performance.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
