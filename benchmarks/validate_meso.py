"""Meso-scale honeycomb (issue 20, first part): writes docs/validation.md's meso section.

1. The walls against plate theory: a cantilever strip's tip deflection and a square
   plate's first two buckling stresses, each on three meshes (serial, seconds).
2. ``meso_compression`` with elastic walls (``fracture=false``; the fracturing walls are
   ``benchmarks/validate_fracture.py``'s) on 2 ranks with the linear buckling analysis,
   on a 1 x 1 and the default 3 x 3 patch: modulus against Gibson and Ashby, buckling
   strain, the curve and the buckled walls. A ``forming study`` in
   ``results/validate_meso`` (a rerun reuses its runs; delete the folder to measure
   again).

Run: ``python benchmarks/validate_meso.py`` (about 20 minutes on 2 cores, nearly all of
it the 3 x 3 patch).
"""

from __future__ import annotations

import shutil
import sys
import time

import numpy as np
from _report import REPO, machine, study_runs, update_section

sys.path.insert(0, str(REPO))

VALIDATION_MD = REPO / "docs" / "validation.md"
FIGURES = REPO / "docs" / "figures"


def wall_checks() -> list[str]:
    """Table rows of the walls' bending and buckling checks."""
    import forming  # noqa: F401  (PETSc before dolfinx)
    from forming.meso.checks import cantilever_ratio, plate_buckling_ratios

    rows = ["| check | mesh | computed / analytic | wall [s] |", "|---|---|---:|---:|"]
    for cells in (5, 10, 20):
        t0 = time.perf_counter()
        ratio = cantilever_ratio(cells)
        rows.append(f"| cantilever strip 20 x 2 x 0.3 mm, tip deflection | {cells} x 1 x 1 "
                    f"| {ratio:.4f} | {time.perf_counter() - t0:.1f} |")
    for cells in (4, 8, 16):
        t0 = time.perf_counter()
        first, second = plate_buckling_ratios(cells)
        spent = time.perf_counter() - t0
        rows.append(f"| square plate 10 x 10 x 0.2 mm, buckling k = 4 / k = 11.1 "
                    f"| {cells} x {cells} x 1 (quarter) | {first:.4f} / {second:.4f} "
                    f"| {spent:.1f} |")
    return rows


def footprint(summary: dict) -> float:
    """The patch's nominal area [mm^2] from a run's parameters."""
    import forming  # noqa: F401
    from forming.meso.honeycomb import HoneycombCell

    p = summary["parameters"]
    cell = HoneycombCell(p["wall_length"], None, p["wall_thickness"], p["angle_deg"],
                         p["double_walls"])
    return p["cells"][0] * p["cells"][1] * cell.area


def main() -> None:
    out = REPO / "results" / "validate_meso"
    lines = ["## Meso-scale honeycomb: cell walls (issue 20, first part)", "",
             "Cell walls of the paper's cardboard (Table 1: E 410 MPa, nu 0.21) as solids "
             "with quadratic hexahedra, one through the wall thickness; estimated cell "
             "dimensions (l = 5 mm, t = 0.30 mm, double ribbon walls; docs/materials.md "
             "§2). Theory: docs/theory.md §15. `python benchmarks/validate_meso.py`; "
             f"{machine()}.", "",
             "### The walls against plate theory (serial)", "", *wall_checks(), ""]
    pairs = study_runs("meso_compression", {"cells": ("1,1", "3,3")}, out,
                       sets=("buckling=true", "fracture=false"), ranks=2,
                       metrics=("modulus_MPa", "peak_stress_MPa", "buckling_strain"))
    pairs += study_runs("meso_compression", {"cells": ("1,1",),
                                             "variant": ("original", "infill", "flange")},
                        out / "contact",
                        sets=("buckling=true", "platen=contact", "fracture=false"), ranks=2,
                        metrics=("modulus_MPa", "peak_stress_MPa", "buckling_strain"))
    lines += ["### `meso_compression`: C365 compression (2 ranks)", "",
              "Elastic walls, seeded imperfection 0.05 mm, viscous stabilisation 2e-4, "
              "strain 0.06, 20 mm high, 8 layers of elements, in-plane size 0.6 mm. The "
              "bottom platen holds the walls; the top one holds them too (bonded) or touches "
              "them with friction 0.36 (contact: the paper's original meso model, and with "
              "`variant=infill` or `variant=flange` its dummy infill or flanges, Table 3).",
              "",
              "| patch | top platen | variant | status | unknowns | relative density "
              "| modulus [MPa] | E_s x rel. density [MPa] | linear buckling strain "
              "| plate buckling strain (k = 4) | stress at the end [MPa] "
              "| largest wall strain | strain reached | stabilisation / internal work "
              "| Newton / step | wall [s] |",
              "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    curves = []
    for row, s in pairs:
        m = s.get("metrics", {})
        h = np.atleast_1d(np.genfromtxt(row.folder / "history.csv", delimiter=",", names=True))
        settings = s.get("parameters", {})
        if not m or len(h) < 2:  # stopped before its first step
            lines.append(f"| {row.values['cells']} | {settings.get('platen', 'bonded')} "
                         f"| {settings.get('variant', 'original')} | {row.status}: "
                         f"{s.get('reason', '')} | {row.unknowns} |" + " |" * 10
                         + f" {row.wall_s:.0f} |")
            continue
        ratio = h["stabilisation_energy_Nmm"][-1] / h["internal_work_Nmm"][-1]
        t = s["timing"]
        lines.append(
            f"| {row.values['cells']} | {s['parameters'].get('platen', 'bonded')} "
            f"| {s['parameters'].get('variant', 'original')} | {s['status']} | {row.unknowns} "
            f"| {m['relative_density']:.4f} | {m['modulus_MPa']:.2f} "
            f"| {m['gibson_ashby_modulus_MPa']:.2f} | {m['buckling_strain']:.4f} "
            f"| {m['plate_buckling_strain']:.4f} | {m['final_stress_MPa']:.3f} "
            f"| {m['max_wall_strain']:.4f} | {m['final_strain']:.4f} | {100 * ratio:.3f}% "
            f"| {t['newton_per_step']:.1f} | {t['wall_s']:.0f} |")
        platen = s["parameters"].get("platen", "bonded")
        force = (-h["reaction_top_z_N"] if platen == "bonded" else h["force_platen_z_N"])
        variant = s["parameters"].get("variant", "original")
        if variant == "infill":
            force = force + (-h["reaction_infill_infill_top_z_N"] if platen == "bonded"
                             else h["force_platen_infill_z_N"])
        elif variant == "flange":
            force = force + (-h["reaction_flange_flange_top_z_N"] if platen == "bonded"
                             else h["force_platen_flange_z_N"])
        curves.append((h["t"] * s["parameters"]["strain"], force / footprint(s),
                       f"{row.values['cells']} cells, platen {platen}, {variant} "
                       f"({s['status']})", "o-"))
        if row.values["cells"] == "3,3" and platen == "bonded":
            e_s, rho = s["parameters"]["wall_modulus"], m["relative_density"]
            png = row.folder / "folded_walls.png"
            if png.is_file():
                shutil.copy(png, FIGURES / "meso_compression_folded_walls.png")
    import forming  # noqa: F401
    from forming.materials.library import honeycomb_core
    from forming.output import plot_curves

    grid = np.linspace(0.0, 0.06, 100)
    curves += [(grid, e_s * rho * grid, "E_s x relative density (Gibson-Ashby)", "k--"),
               (grid, honeycomb_core("isotropic").curve.interpolate(grid),
                "macro model's C365 curve (estimate of Fig. 6)", "k:")]
    plot_curves(FIGURES / "meso_compression_stress_strain.png", curves, "nominal strain",
                "nominal stress [MPa]", "Meso compression: elastic cell walls")
    lines += ["", "![meso stress-strain](figures/meso_compression_stress_strain.png)",
              "![buckled walls](figures/meso_compression_folded_walls.png)", "",
              "What it shows, and what it does not yet:", "",
              "- The initial modulus is E_s x relative density (Gibson and Ashby) within a "
              "few per cent: the walls carry the load axially, the bonded platens add a "
              "little Poisson restraint.",
              "- The single (inclined) walls buckle first, at the linear buckling strain in "
              "the table (between the k = 4 simply supported plate and a clamped plate: the "
              "junctions restrain the walls' edges); the stiffness then drops but the "
              "double ribbon walls carry on, so an elastic-wall patch shows no peak at these "
              "strains. The measured core peaks at 0.40 MPa and 0.03 strain: the missing "
              "piece is the walls' failure (fracture at 0.067 strain, Table 1; the largest "
              "wall strain column shows the walls reach it): the fracturing walls are in "
              "the section 'Meso-scale honeycomb: fracturing cell walls'.",
              "- Patch size: 1 x 1 and 3 x 3 agree to the buckling strain (moduli 1.3% "
              "apart) and part after it (the 3 x 3 patch 29% stiffer at 6% strain): "
              "the cut walls at a patch's sides stand free, and in a 1 x 1 patch they are "
              "most of the walls. "
              "Whether 3 x 3 is a representative volume (the issue asks for a larger patch "
              "within 5%) is not measured yet: a 5 x 5 patch is about 4 times the unknowns.",
              "- The viscous stabilisation carries the runs through the walls' buckling with "
              "the dissipated energy in the table, a small share of the internal work. "
              "Without it (`mpirun -n 2 python cases/meso_compression.py --set "
              "fracture=false --set stabilisation=0`) the 3 x 3 patch stalled at 5.0% "
              "strain: the step was cut to 2e-4 of the stroke and the run was stopped by "
              "hand after 18 minutes.",
              "- A touching platen (friction 0.36) stops every variant short of 6% strain, "
              "as the paper's original meso model did not converge in Abaqus/Explicit "
              "(tool-wall penetration, Table 2). Original: wall edges fold under the "
              "platen until elements invert (contact holds the edges' vertices, not their "
              "midside nodes). Dummy infill: Newton stops converging from 2.8% strain, "
              "earlier than without it. Dummy flanges: Newton fails in the first step "
              "with friction; frictionless (`python cases/meso_compression.py --set "
              "fracture=false --set cells=1,1 --set height=10 --set layers=3 --set "
              "strain=0.01 --set variant=flange --set platen=contact --set "
              "platen_friction=0`) it runs, but "
              "the modulus is 8% low and a wall strains 8.8% locally at 1% nominal strain, "
              "so the flange-platen contact is not trusted yet. The paper's remedies work "
              "in its explicit code; ours, implicit, need more (explicit meso runs, "
              "contact at the quadratic walls' midside nodes). These touching-platen rows "
              "predate the platen touching every node of the quadratic faces (ea230d0) and "
              "the dummies' bonds at all nine nodes (b1a2e7d): 'Meso variants past the "
              "peak' has the three variants rerun, implicit and explicit.",
              "- Since this section: wall-to-wall contact, explicit meso runs, "
              "`meso_crushing`, `meso_hemisphere`, `forming calibrate` with the in-plane "
              "moduli, and the patch size in compression with fracturing walls (1 x 1, "
              "3 x 3 and 4 x 4 cells, explicit: 'Meso patch size'; sections below)."]
    update_section("meso", "\n".join(lines), VALIDATION_MD)
    cost = ["## Meso-scale cases", "",
            "Written by `python benchmarks/validate_meso.py` (docs/validation.md, meso "
            f"section, has the results); 2 ranks, {machine()}. The paper's Abaqus/Explicit "
            "meso runs took 164.9 s (dummy flanges) to 323.7 s (original, did not converge), "
            "Table 2; ours are implicit with elastic walls, not the same model.", "",
            "| case | patch | top platen | variant | status | unknowns | steps "
            "| Newton iterations | wall [s] |",
            "|---|---|---|---|---|---:|---:|---:|---:|"]
    for row, summary in pairs:
        settings = summary.get("parameters", {})
        cost.append(f"| meso_compression (buckling=true) | {row.values['cells']} "
                    f"| {settings.get('platen', 'bonded')} "
                    f"| {settings.get('variant', 'original')} | {row.status} "
                    f"| {row.unknowns} | {row.steps} | {row.newton_iterations} "
                    f"| {row.wall_s:.0f} |")
    update_section("meso_cost", "\n".join(cost))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
