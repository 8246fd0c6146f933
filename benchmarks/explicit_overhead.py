"""The explicit solver's fixed cost per increment, on small scenes, against a checkout.

On a model of a few dozen elements an increment's time is mostly the Python around the
compiled loops (calls per body, tool and term, array views, load updates), not the
element work: the cost a user pays on a small model and the test suite pays on every
explicit test. For each scene: microseconds per increment of the time integration (the
output intervals' solves, ``history.csv`` ``step_wall_s``, over the increments), this
tree against ``--before`` (a checkout of an earlier revision), the two alternated
``--repeats`` times so that the machine's drift falls on both alike; the median of each
and their ratio. The punch forces of the two must agree (same increments, same answer).

Writes docs/performance.md's ``explicit_overhead`` section.

Run: ``python benchmarks/explicit_overhead.py --before /path/to/checkout [--repeats 3]``
(about 7 minutes with 3 repeats, after a first pass that fills the kernel caches;
nothing else should run meanwhile).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, machine, run_case_process, update_section

# (label, case, settings): small explicit scenes, as the suite runs them
SCENES = (
    ("core_crushing 4 x 4 x 3, reduced (48 elements)", "core_crushing",
     ("cells=4,4,3", "explicit.integration=reduced")),
    ("core_crushing 4 x 4 x 2, full, 3 mm (32 elements)", "core_crushing",
     ("cells=4,4,2", "stroke=3")),
    ("hemisphere 6 x 6 x 2, full, 10 mm (72 elements)", "hemisphere",
     ("cells=6,6,2", "stroke=10")),
)


def _per_increment(summary: dict, out: Path) -> tuple[float, float | None, int]:
    """(us per increment, punch force max, increments) of a run."""
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    steps = summary["timing"]["time_steps"]
    return (1e6 * float(np.sum(hist["step_wall_s"])) / steps,
            summary["metrics"].get("punch_force_max_N"), steps)


def _revision(repo: Path) -> str:
    """The checkout's short revision, with ``+`` when its tree differs from it."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=repo, text=True, capture_output=True,
                              check=False).stdout.strip()
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", "forming", "cases")
    return (git("rev-parse", "--short", "HEAD") or "?") + ("+" if dirty else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--before", type=Path, required=True,
                        help="a checkout of the revision to compare with")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    trees = {"before": args.before, "now": REPO}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, case, sets in SCENES:
            got: dict[str, list] = {k: [] for k in trees}
            for k in range(-1, args.repeats):  # the first pass compiles (not counted)
                for name, repo in trees.items():
                    out = Path(tmp) / f"{case}_{name}_{k}_{len(rows)}"
                    s = run_case_process(case, out, sets=("solver=explicit", *sets),
                                         repo=repo)
                    if k < 0:
                        continue
                    got[name].append(_per_increment(s, out))
                    print(label, name, got[name][-1], flush=True)
            med = {n: statistics.median(r[0] for r in got[n]) for n in trees}
            rows.append({"scene": label, "before": med["before"], "now": med["now"],
                         "force": {n: got[n][0][1] for n in trees},
                         "increments": {n: got[n][0][2] for n in trees}})
    lines = [
        "## Explicit solver: the fixed cost of an increment on small models (issue 16)", "",
        f"`python benchmarks/explicit_overhead.py --before <checkout> --repeats "
        f"{args.repeats}` on {machine()}: before {_revision(args.before)}, now "
        f"{_revision(REPO)}, the two alternated; the median over the repeats of the "
        "integration's wall time per increment. Serial, explicit, the case's defaults "
        "otherwise.", "",
        "| scene | increments | before [us / increment] | now [us / increment] "
        "| speed-up | punch force max before / now [N] |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        f = r["force"]
        lines.append(f"| {r['scene']} | {r['increments']['now']} | {r['before']:.0f} "
                     f"| {r['now']:.0f} | {r['before'] / r['now']:.2f}x "
                     f"| {f['before']:.6f} / {f['now']:.6f} |")
    update_section("explicit_overhead", "\n".join(lines), REPO / "docs" / "performance.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
