"""The dummy-flange runs of the meso cost target, with inverted points eroded (issue 20).

The two runs of ``validate_meso_rve.py``'s cost target (``meso_compression`` on 3 x 3
cells with the paper's dummy flanges, touching platen, explicit, to 0.1 strain on 2
ranks) stopped at 0.096-0.098 strain on an inverted element: of a flange where the
dummies are kept, of a wall's top where they are deleted at Table 3's strain. Here the
same two runs with ``--set explicit.erode_inverted=true``: a point of an eroding body
whose element inverts is eroded, as LS-DYNA's ``ERODE`` deletes solids of negative
volume, instead of stopping the run. Written to docs/validation.md (section
``meso_erode_inverted``): whether they finish, how many points erode where, the curve,
and the wall time against the paper's 164.9 s.

Runs are in ``results/meso_inverted_erosion`` (a rerun reuses every run that ended).

Run: ``python benchmarks/meso_inverted_erosion.py`` (about 40 minutes on 2 cores);
``--report`` writes the section from the runs already there.
"""

from __future__ import annotations

import argparse
import sys

from _report import REPO, machine, update_section
from validate_meso_explicit import commit, curve, status_text
from validate_meso_rve import (
    FLANGE_PATCH,
    FLANGE_SETS,
    PAPER_FLANGE_S,
    FolderRow,
    run_or_reuse,
    us_text,
)

VALIDATION_MD = REPO / "docs" / "validation.md"
FIGURE = REPO / "docs" / "figures" / "meso_inverted_erosion.png"
OUT = REPO / "results" / "meso_inverted_erosion"
ERODE = "explicit.erode_inverted=true"
# (folder, label, extra --set items): the cost target's two runs, eroding
RUNS = (("flange-3-3", "dummies kept", ()),
        ("flange-3-3-deleted", "dummies deleted at Table 3's strain (`dummy_deletion=true`)",
         ("dummy_deletion=true",)))
# where the runs without the option stopped (docs/performance.md, 'meso_compression:
# patch size and cost', measured on 2026-11-28 with validate_meso_rve.py)
STOPPED_AT = {"flange-3-3": 0.098, "flange-3-3-deleted": 0.096}


def _eroded(metrics: dict) -> str:
    """Points eroded on inversion: the total, and each body's."""
    bodies = {k.removeprefix("inverted_points_eroded_"): v for k, v in metrics.items()
              if k.startswith("inverted_points_eroded_")}
    return (f"{metrics.get('inverted_points_eroded', 0)} ("
            + ", ".join(f"{b} {n}" for b, n in bodies.items()) + ")")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", action="store_true",
                        help="write the section from the runs in the folder, run none")
    args = parser.parse_args()
    cells, ranks = FLANGE_PATCH
    runs = [(name, label, OUT / name,
             run_or_reuse(OUT / name, ranks, (f"cells={cells}", *FLANGE_SETS, ERODE, *extra),
                          args.report))
            for name, label, extra in RUNS]
    lines = ["## The dummy-flange cost runs with inverted points eroded (issue 20)", "",
             f"`python benchmarks/meso_inverted_erosion.py` on {machine()}, each run alone "
             f"on the machine, {ranks} ranks: `meso_compression` with the settings of the "
             "cost target ('Meso patch size', below: `"
             + " ".join(f"--set {x}" for x in (f"cells={cells}", *FLANGE_SETS))
             + f"`) and `--set {ERODE}`. Without the option both runs stopped on an "
             "inverted element before the end (docs/performance.md, 'meso_compression: "
             "patch size and cost').", "",
             "| dummies | status | strain reached (without the option) | points eroded on "
             "inversion | peak [MPa] at strain | stress at the end [MPa] | kinetic / internal "
             "max | wall [s] (paper 164.9) | us per element and increment | commit |",
             "|---|---|---|---:|---|---:|---:|---:|---:|---|"]
    curves = []
    for name, label, folder, summary in runs:
        m, t = summary.get("metrics", {}), summary.get("timing", {})
        if not t:
            lines.append(f"| {label} | {summary.get('status', 'not run')} |" + " |" * 8)
            continue
        e, s = curve(FolderRow(folder, summary), summary)
        curves.append((label, e, s))
        lines.append(
            f"| {label} | {status_text(FolderRow(folder, summary), summary)} "
            f"| {m.get('final_strain', float('nan')):.3f} ({STOPPED_AT[name]:.3f}) "
            f"| {_eroded(m)} "
            f"| {m.get('peak_stress_MPa', float('nan')):.3f} at "
            f"{m.get('peak_strain', float('nan')):.3f} | {s[-1]:.3f} "
            f"| {100 * m.get('kinetic_to_internal_max', float('nan')):.1f}% "
            f"| {t['wall_s']:.0f} ({t['wall_s'] / PAPER_FLANGE_S:.1f}x) "
            f"| {us_text(folder, summary)} | {commit(summary)} |")
    if curves:
        sys.path.insert(0, str(REPO))
        import forming  # noqa: F401  (PETSc before dolfinx)
        from forming.output import plot_curves

        plot_curves(FIGURE, curves, "nominal strain", "nominal stress [MPa]",
                    "Meso compression, dummy flanges, inverted points eroded")
        lines += ["", f"![inverted points eroded](figures/{FIGURE.name})"]
    update_section("meso_erode_inverted", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
