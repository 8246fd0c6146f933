"""The explicit solver's fixed cost per increment, on small scenes, against a checkout.

On a model of a few dozen elements an increment's time is mostly the Python around the
compiled loops (calls per body, tool and term, array views, load updates), not the
element work: the cost a user pays on a small model and the test suite pays on every
explicit test. For each scene: microseconds per increment of the time integration (the
output intervals' solves, ``history.csv`` ``step_wall_s``, over the increments), this
tree against ``--before`` (a checkout of an earlier revision), the two alternated
``--repeats`` times so that the machine's drift falls on both alike; the median of each
and their ratio. Each scene's answer (a force of its summary) is shown for both trees:
the same increments and answer mean the change removed calls, not arithmetic.

Writes docs/performance.md's ``explicit_overhead`` section.

Run: ``python benchmarks/explicit_overhead.py --before /path/to/checkout [--repeats 3]``
(about 10 minutes with 3 repeats, after a first pass that fills the kernel caches;
nothing else should run meanwhile).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, machine, revision, run_case_process, update_section

# (label, case, settings, the answer compared): small explicit scenes, as the suite runs them
SCENES = (
    ("core_crushing 4 x 4 x 3, reduced (48 elements)", "core_crushing",
     ("cells=4,4,3", "explicit.integration=reduced"), "punch_force_max_N"),
    ("core_crushing 4 x 4 x 2, full, 3 mm (32 elements)", "core_crushing",
     ("cells=4,4,2", "stroke=3"), "punch_force_max_N"),
    ("hemisphere 6 x 6 x 2, full, 10 mm (72 elements)", "hemisphere",
     ("cells=6,6,2", "stroke=10"), "punch_force_max_N"),
    ("sliding_sled, a skin sliding 1 mm on the core (153 elements)", "sliding_sled",
     ("drag=1", "skin_cells=5", "explicit.loading_time=0.01"), "drag_force_N"),
)


def _per_increment(summary: dict, out: Path, answer: str) -> tuple[float, float | None, int]:
    """(us per increment, the metric ``answer``, increments) of a run."""
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    steps = summary["timing"]["time_steps"]
    return (1e6 * float(np.sum(hist["step_wall_s"])) / steps,
            summary["metrics"].get(answer), steps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--before", type=Path, required=True,
                        help="a checkout of the revision to compare with")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    trees = {"before": args.before, "now": REPO}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, case, sets, answer in SCENES:
            got: dict[str, list] = {k: [] for k in trees}
            for k in range(-1, args.repeats):  # the first pass compiles (not counted)
                for name, repo in trees.items():
                    out = Path(tmp) / f"{case}_{name}_{k}_{len(rows)}"
                    s = run_case_process(case, out, sets=("solver=explicit", *sets),
                                         repo=repo)
                    if k < 0:
                        continue
                    got[name].append(_per_increment(s, out, answer))
                    print(label, name, got[name][-1], flush=True)
            med = {n: statistics.median(r[0] for r in got[n]) for n in trees}
            rows.append({"scene": label, "answer": answer,
                         "before": med["before"], "now": med["now"],
                         "force": {n: got[n][0][1] for n in trees},
                         "increments": {n: got[n][0][2] for n in trees}})
    lines = [
        "## Explicit solver: the fixed cost of an increment on small models (issue 16)", "",
        f"`python benchmarks/explicit_overhead.py --before <checkout> --repeats "
        f"{args.repeats}` on {machine()}: before {revision(args.before)}, now "
        f"{revision(REPO)}, the two alternated; the median over the repeats of the "
        "integration's wall time per increment. Serial, explicit, the case's defaults "
        "otherwise.", "",
        "| scene | increments | before [us / increment] | now [us / increment] "
        "| speed-up | answer | before / now [N] |",
        "|---|---:|---:|---:|---:|---|---|",
    ]
    for r in rows:
        f = r["force"]
        lines.append(f"| {r['scene']} | {r['increments']['now']} | {r['before']:.0f} "
                     f"| {r['now']:.0f} | {r['before'] / r['now']:.2f}x | `{r['answer']}` "
                     f"| {f['before']:.10g} / {f['now']:.10g} |")
    update_section("explicit_overhead", "\n".join(lines), REPO / "docs" / "performance.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
