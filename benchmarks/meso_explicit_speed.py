"""Cost of an explicit meso increment, before and after a change (issues 16 and 20).

``meso_compression`` with fracturing walls that touch each other, bonded platens,
explicit (the settings of ``validate_meso_rve.py``: 10 mm core in 4 layers, mass scaling
to a 2e-7 s step, nominal strain rate 62.5/s), to ``--strain`` on the 1 x 1 patch
(serial) and the 3 x 3 patch (2 ranks), run with this checkout and with ``--before`` (a
checkout of an earlier revision: ``git worktree add /tmp/old REV``), one after the other.
Both must take the same increments and reach the same stresses: the table says how far
apart they are.

Writes docs/performance.md ``meso_explicit_speed``; runs in
``results/meso_explicit_speed`` (a rerun measures again).

Run: ``python benchmarks/meso_explicit_speed.py --before /tmp/old`` (about 20 minutes on
2 cores at the default strain; nothing else should run meanwhile).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import numpy as np
from _report import REPO, machine, revision, run_case_process, update_section

PERFORMANCE_MD = REPO / "docs" / "performance.md"
OUT = REPO / "results" / "meso_explicit_speed"
RATE = 62.5  # nominal strain rate [1/s]
PATCHES = (("1,1", 1), ("3,3", 2))


def sets(cells: str, strain: float) -> tuple[str, ...]:
    """The ``--set`` items of one run."""
    return (f"cells={cells}", "height=10", "layers=4", f"strain={strain:g}",
            "solver=explicit", "stabilisation=0", "explicit.target_time_step=2e-7",
            f"explicit.loading_time={strain / RATE:g}")


def stress(folder: Path) -> np.ndarray:
    """The platen's force history of a run [N]."""
    h = np.atleast_1d(np.genfromtxt(folder / "history.csv", delimiter=",", names=True))
    return h["reaction_top_z_N"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True,
                        help="checkout of the earlier revision")
    parser.add_argument("--strain", type=float, default=0.1)
    args = parser.parse_args()
    shutil.rmtree(OUT, ignore_errors=True)
    lines = ["## Explicit meso increments: before and after", "",
             f"Written by `python benchmarks/meso_explicit_speed.py --before <checkout>`; "
             f"{machine()}; the runs one after the other, nothing else running. "
             "`meso_compression`, fracturing walls that touch, bonded platens, 10 mm core "
             f"in 4 layers, explicit, to {args.strain:g} strain at {RATE:g}/s with mass "
             "scaling to a 2e-7 s step. Integration: the time integration's wall time "
             "(`timing.integration_s`).", "",
             "| cells | ranks | revision | increments | elements | integration [s] "
             "| us per element and increment | speed-up | platen force, largest difference "
             "from before |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    for cells, ranks in PATCHES:
        rows = {}
        for tag, repo in (("before", args.before.resolve()), ("after", REPO)):
            folder = OUT / f"{tag}-{cells.replace(',', '-')}"
            summary = run_case_process("meso_compression", folder, ranks,
                                       sets=sets(cells, args.strain), repo=repo)
            rows[tag] = (revision(repo), summary, summary["timing"]["integration_s"],
                         stress(folder))
        base = rows["before"][2]
        f_ref = rows["before"][3]
        for tag in ("before", "after"):
            rev, summary, integ, force = rows[tag]
            t = summary["timing"]
            diff = (float(np.max(np.abs(force - f_ref)) / np.max(np.abs(f_ref)))
                    if force.shape == f_ref.shape else float("nan"))
            lines.append(f"| {cells.replace(',', ' x ')} | {ranks} | {rev} "
                         f"| {t['time_steps']} | {t['elements']} | {integ:.1f} "
                         f"| {t['us_per_element_increment']:.1f} | {base / integ:.2f} "
                         f"| {diff:.1e} |")
    lines += ["", "What the increment spends, as of 5fade8e: the walls' internal forces in the "
              "compiled element loops of the P1 core (`forming/bodies/hexforce.py`, 27 points "
              "per P2 hexahedron, the body's own damage arrays) instead of a UFL expression "
              "for C, the point update and a form assembly; the self-contact search with "
              "each triangle's normal computed once per search instead of once per "
              "candidate pair (about 55 candidate triangles per surface node on these "
              "walls). What is left, by a sampling profile of the 1 x 1 run (`py-spy "
              "record`): the fracturing material's point update about 40%, the element "
              "loops about 22%, the self-contact search about 24%."]
    update_section("meso_explicit_speed", "\n".join(lines), PERFORMANCE_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
