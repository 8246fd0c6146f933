"""The paper's three meso variants past the peak (issue 20): docs/validation.md ``meso_variants``.

``meso_compression`` on the 1 x 1 patch with a touching top platen (friction 0.36, the
augmented stick law), fracturing walls that touch each other, explicit, to ``--strain``
(0.25 by default): original (the platen on the wall edges), dummy flanges, dummy
infill (paper, Table 3). The issue asks for their plateaus within 10% of each other
(the paper: the dummies do not change the response significantly). Each plateau is the
mean stress from twice the peak strain to the end of the run; it is given for the whole
platen force and for the walls' share alone (the force of the platen on the walls'
edges), so the dummies' own stiffness is seen apart.

The same three with the implicit solver (the case's defaults: elastic-slip stick, viscous
stabilisation 2e-4), to ``--implicit-strain`` (0.06 by default, past the walls' peak):
which converge, and how far.

Runs are a ``forming study`` in ``results/validate_meso_variants`` (a rerun reuses
them; delete the folder to measure again), two at a time (``--jobs``), each serial: the
wall times are of runs that shared the 2-core machine with one other.

Run: ``python benchmarks/validate_meso_variants.py`` (about an hour on 2 cores: the
original explicit run slows down past 0.2 strain, and an implicit run that stalls must
be interrupted by hand); ``--report`` writes the section from the runs in the folder
(interrupted ones included) without running any: a plain rerun would run an interrupted
one again.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from _report import REPO, machine, update_section
from validate_meso import footprint
from validate_meso_explicit import (
    PAPER_TABLE2,
    commit,
    curve,
    explicit_sets,
    regions,
    runs_or_report,
    status_text,
)

sys.path.insert(0, str(REPO))

VALIDATION_MD = REPO / "docs" / "validation.md"
FIGURES = REPO / "docs" / "figures"
VARIANTS = ("original", "flange", "infill")


def walls_curve(row, summary: dict) -> tuple[np.ndarray, np.ndarray]:
    """Nominal strain and the stress of the platen on the walls' edges alone."""
    h = np.atleast_1d(np.genfromtxt(row.folder / "history.csv", delimiter=",", names=True))
    e = h["t"] * summary["parameters"]["strain"]
    return e, h["force_platen_z_N"] / footprint(summary)


def common_window(pairs: list) -> list[str]:
    """The plateaus over the strains every run reached past 1.5 times the largest peak."""
    runs = [(row.values["variant"], row, s) for row, s in pairs if s.get("metrics")]
    start = 1.5 * max(s["metrics"]["peak_strain"] for _v, _r, s in runs)
    end = min(s["metrics"]["final_strain"] for _v, _r, s in runs)
    if end <= start:
        return []
    found = []
    for v, row, s in runs:
        e, total = curve(row, s)
        _e, walls = walls_curve(row, s)
        band = (e >= start) & (e <= end)
        found.append((v, float(total[band].mean()), float(walls[band].mean())))
    spread = [100 * (max(x) / min(x) - 1) for x in zip(*[f[1:] for f in found], strict=True)]
    return [f"- Over the strains every run reached past 1.5 times the largest peak strain, "
            f"{start:.3f} to {end:.3f}: whole platen "
            + ", ".join(f"{v} {t:.3f}" for v, t, _w in found) + " MPa (they differ by "
            f"{spread[0]:.0f}%); the walls' shares "
            + ", ".join(f"{v} {w:.3f}" for v, _t, w in found) + f" MPa ({spread[1]:.0f}%)."]


def plateaus_of(row, summary: dict) -> tuple:
    """A run's curves and plateaus: (strain, whole platen, walls' share, (both plateaus))."""
    peak = summary["metrics"]["peak_strain"]
    e, total = curve(row, summary)
    _e, walls = walls_curve(row, summary)
    return e, total, walls, (regions(e, total, peak)[0], regions(e, walls, peak)[0])


def run_cells(row, summary: dict) -> str:
    """The first cells of a run's row: variant, status, strain reached, peak."""
    m = summary["metrics"]
    return (f"| {row.values['variant']} | {status_text(row, summary)} | "
            f"{m['final_strain']:.4f} | {m['peak_stress_MPa']:.3f} at {m['peak_strain']:.4f}")


def deletion_rows(deleted: list, original: tuple[float, float] | None) -> list[str]:
    """The dummies deleted at Table 3's fracture strains (``dummy_deletion=true``)."""
    lines = ["", "The dummies deleted where their largest principal strain reaches Table 3's "
             "fracture strain (flanges 0.067, infill 0.010; in compression as in tension; "
             "`--set dummy_deletion=true`), otherwise the same runs:", "",
             "| variant | status | strain reached | peak [MPa] at strain | plateau [MPa] "
             "| the walls' share [MPa] | plateau over the original's | wall [s] | commit |",
             "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for row, s in deleted:
        v, m = row.values["variant"], s.get("metrics", {})
        if not m:
            lines.append(f"| {v} | {status_text(row, s)} |" + " |" * 6 + f" {commit(s)} |")
            continue
        both = plateaus_of(row, s)[3]
        ratio = f"{both[0] / original[0]:.2f}" if original else ""
        lines.append(f"{run_cells(row, s)} | {both[0]:.3f} | {both[1]:.3f} | {ratio} "
                     f"| {s['timing']['wall_s']:.0f} | {commit(s)} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--strain", type=float, default=0.25)
    parser.add_argument("--implicit-strain", type=float, default=0.06)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--report", action="store_true",
                        help="write the section from the runs in the folder, run none")
    args = parser.parse_args()
    out = REPO / "results" / "validate_meso_variants"

    def runs(sub: str, sets: tuple[str, ...], variants: tuple[str, ...] = VARIANTS) -> list:
        return runs_or_report(args.report, "meso_compression", {"variant": variants},
                              out / sub, sets, args.jobs)

    explicit = explicit_sets(args.strain, "cells=1,1", "platen=contact",
                             "platen_stick=augmented")
    pairs = runs("explicit", explicit)
    deleted = runs("explicit_deletion", (*explicit, "dummy_deletion=true"), VARIANTS[1:])
    implicit = runs("implicit", (f"strain={args.implicit_strain:g}", "cells=1,1",
                                 "platen=contact"))
    lines = ["## Meso variants past the peak (issue 20)", "",
             "The paper's three meso variants (Table 3) on the 1 x 1 patch: fracturing walls "
             "that touch each other, a touching top platen (friction 0.36, augmented stick), "
             f"explicit (as 'explicit runs, walls that touch'), to {args.strain:g} nominal "
             "strain. Plateau: the mean stress from twice the peak strain to the end; the "
             "walls' share is the platen's force on the walls' edges alone. "
             "`python benchmarks/validate_meso_variants.py`; two runs at a time, each "
             f"serial; {machine()}.", "",
             "| variant | status | strain reached | peak [MPa] at strain | plateau [MPa] "
             "| the walls' share [MPa] | dummy's share of the plateau | kinetic / internal "
             "at most | wall [s] | paper, Table 2 | commit |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|"]
    plateaus: dict[str, tuple[float, float]] = {}
    curves = []
    for row, s in pairs:
        v, m = row.values["variant"], s.get("metrics", {})
        if not m:
            lines.append(f"| {v} | {status_text(row, s)} |" + " |" * 7
                         + f" {PAPER_TABLE2[v]} | {commit(s)} |")
            continue
        e, total, walls, both = plateaus_of(row, s)
        plateaus[v] = both
        lines.append(
            f"{run_cells(row, s)} | {both[0]:.3f} "
            f"| {both[1]:.3f} | {100 * (1 - both[1] / both[0]):.0f}% "
            f"| {100 * m['kinetic_to_internal_max']:.1f}% | {s['timing']['wall_s']:.0f} "
            f"| {PAPER_TABLE2[v]} | {commit(s)} |")
        curves += [(e, total, f"{v}: whole platen", "-"), (e, walls, f"{v}: walls' share", ":")]
    if len(plateaus) == len(VARIANTS):
        total = np.array([plateaus[v][0] for v in VARIANTS])
        walls = np.array([plateaus[v][1] for v in VARIANTS])
        spread = [100 * (x.max() / x.min() - 1) for x in (total, walls)]
        lines += ["", f"- The plateaus differ by {spread[0]:.0f}% (largest over smallest), "
                  f"the walls' shares by {spread[1]:.0f}%; the issue's target is 10%."]
        lines += common_window(pairs)
    lines += deletion_rows(deleted, plateaus.get("original"))
    original = [(row, s) for row, s in pairs if row.values["variant"] == "original"]
    if original and all(s.get("metrics") for _row, s in deleted):
        lines += ["", "With the original run, the flanges and the infill deleted:"]
        lines += common_window(original + deleted)
        lines += ["- Deleted, the dummies carry nothing past the peak (the walls' share is the "
                  "whole plateau) and the peaks come within 6% of the original's; the plateau "
                  "of a 1 x 1 patch is a few folds, whose force swings between about 4 and 15 N, "
                  "so its mean depends on the window and on where the folds fall: 0.66-0.68 of "
                  "the original's by the case's window, 0.71-0.99 over the common one. The 10% "
                  "target is met by neither measure; a larger patch would average the folds "
                  "(not run: the original's run took 37 minutes on 1 x 1)."]
    lines += ["", f"With the implicit solver, to {args.implicit_strain:g} (the case's defaults: "
              "elastic-slip stick law, viscous stabilisation 2e-4, erosion of spent points):",
              "", "| variant | status | strain reached | peak [MPa] at strain "
              "| stress at the end [MPa] | Newton iterations | wall [s] | commit |",
              "|---|---|---:|---:|---:|---:|---:|---|"]
    for row, s in implicit:
        v, m = row.values["variant"], s.get("metrics", {})
        if not m:
            lines.append(f"| {v} | {status_text(row, s)} |" + " |" * 5 + f" {commit(s)} |")
            continue
        e, total = curve(row, s)
        lines.append(
            f"{run_cells(row, s)} | {m['final_stress_MPa']:.3f} "
            f"| {s['timing'].get('newton_iterations', '')} "
            f"| {s['timing']['wall_s']:.0f} | {commit(s)} |")
        curves.append((e, total, f"{v}: implicit", "--"))
    lines += ["", "- Why the explicit plateaus of the first table are not within 10%: the "
              "paper's dummies fracture and are deleted (Table 3: the flanges at 0.067, the "
              "infill at 0.010, 'to minimise additional resistance to buckling'); there ours "
              "stay elastic and bonded (deleted: the second table). "
              "The infill then carries much of the plateau itself and, bonded to the walls, "
              "holds them from folding (a later peak, a larger walls' share past it); the "
              "flanges carry part of the force until one of their elements, crushed between "
              "the platen and a folding wall, inverts.",
              "- The implicit runs stop before 0.06: the original where wall elements under "
              "the platen invert, the flanges where Newton stops converging, the infill where "
              "the step is cut below a thousandth of the stroke without converging (it was "
              "interrupted by hand). The paper's original model did not converge either "
              "(Table 2); its dummies did, in Abaqus/Explicit, as ours do explicitly."]
    if curves:
        import forming  # noqa: F401  (PETSc before dolfinx)
        from forming.output import plot_curves

        plot_curves(FIGURES / "meso_variants_stress_strain.png", curves, "nominal strain",
                    "nominal stress [MPa]", "Meso variants, touching platen, explicit")
        lines += ["", "![meso variants](figures/meso_variants_stress_strain.png)"]
    update_section("meso_variants", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
