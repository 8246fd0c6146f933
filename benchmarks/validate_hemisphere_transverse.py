"""Hemisphere forming of the transversely isotropic core: writes docs/validation.md's section.

1. The transverse core on the default mesh (20 x 20 x 4), with and without blank holder,
   serial, and the holder variant on 2 ranks: the columns of the isotropic table.
2. Both cores on the coarse 12 x 12 x 3 mesh with the same contact numerics (elastic-slip
   stick, full Newton steps: what ``auto`` picks for the transverse core), and the
   isotropic core with its own (augmented stick, backtracking): which differences come
   from the core and which from the contact numerics.
3. Bending of a core strip over the die (``strip_bending``) against beam theory: how
   far the 8-node hexahedra overstiffen the transverse core's bending (shear locking).

Run: ``python benchmarks/validate_hemisphere_transverse.py`` (about 30 minutes on 2 cores;
``--quick`` runs a 8 x 8 x 2 mesh and a 5 mm stroke to check the script).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from _report import REPO, run_case_process, update_section
from validate_hemisphere import _row

SAME = ("tool_stick=elastic_slip", "line_search=basic")


def _change(new: float, ref: float) -> str:
    """Relative change of ``new`` against ``ref`` (``-`` when ``ref`` is zero)."""
    return f"{new / ref - 1:+.2%}" if ref else "-"


def _coarse_row(core: str, holder: bool, numerics: str, s: dict) -> str:
    m = s["metrics"]
    return (f"| {core} | {holder} | {numerics} | {s['status']} "
            f"| {m['punch_force_max_N']:.1f} | {m['crushed_volume_mm3']:.0f} "
            f"| {m['crushed_volume_under_punch_mm3']:.0f} "
            f"| {m['crushing_strain_mean_under_punch']:.4f} "
            f"| {m['crushing_strain_max']:.3f} | {m['dilation_strain_max']:.3f} "
            f"| {m['edge_lift_max_mm']:.2f} | {s['timing']['newton_per_step']:.1f} "
            f"| {s['timing']['wall_s']:.0f} |")


def main(quick: bool = False) -> None:
    mesh = ("cells=8,8,2", "stroke=5") if quick else ()
    coarse = ("cells=8,8,2", "stroke=5") if quick else ("cells=12,12,3",)
    lines = ["## Hemisphere forming with the transversely isotropic core (issue 6)", "",
             "`python benchmarks/validate_hemisphere_transverse.py`. The case with "
             "`--set elasticity=transverse`: E = 15 MPa through the thickness, 0.2 MPa "
             "in-plane, G = 1.56 MPa transverse shear, biot-hencky strain, the shipped C365 "
             "curve, eta = 0.15 MPa mm; `auto` contact numerics: Coulomb friction with "
             "elastic slip on the tools and full Newton steps (docs/theory.md, section 13).",
             "", "### Default mesh (20 x 20 x 4)", "",
             "| blank holder | status | stroke [mm] | punch force max [N] "
             "| crushed volume [mm^3] | under punch [mm^3] | mean crushing strain under punch "
             "| crushing strain max | dilation max | edge lift [mm] | punch gap max [mm] "
             "| penetration / tolerance [mm] | Newton/step | wall [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        runs = {}
        for holder, ranks in ((False, 1), (True, 1), (True, 2)):
            s = run_case_process("hemisphere", tmp / f"t{holder}{ranks}", ranks=ranks,
                                 allow_failure=True,
                                 sets=(*mesh, "elasticity=transverse", f"blank_holder={holder}"))
            runs[holder, ranks] = s
            lines.append(_row(f"{holder}" + (f" ({ranks} ranks)" if ranks > 1 else ""), s))
        one, two = runs[True, 1]["metrics"], runs[True, 2]["metrics"]
        lines += ["", "Two ranks against one (holder): punch force max "
                  f"{_change(two['punch_force_max_N'], one['punch_force_max_N'])}, crushed "
                  f"volume {_change(two['crushed_volume_mm3'], one['crushed_volume_mm3'])}.",
                  "", "### Both cores, same contact numerics (12 x 12 x 3)", "",
                  "| core | blank holder | contact numerics | status | punch force max [N] "
                  "| crushed volume [mm^3] | under punch [mm^3] "
                  "| mean crushing strain under punch | crushing strain max | dilation max "
                  "| edge lift [mm] | Newton/step | wall [s] |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        coarse_runs = {}
        for holder in (False, True):
            for core, numerics, sets in (
                    ("transverse", "elastic slip, full steps", SAME),
                    ("isotropic", "elastic slip, full steps", SAME),
                    ("isotropic", "augmented, backtracking", ())):
                s = run_case_process("hemisphere", tmp / f"c{core}{holder}{len(sets)}",
                                     allow_failure=True,
                                     sets=(*coarse, f"elasticity={core}",
                                           f"blank_holder={holder}", *sets))
                coarse_runs[core, holder, bool(sets)] = s["metrics"]
                lines.append(_coarse_row(core, holder, numerics, s))
        key = "crushed_volume_under_punch_mm3"
        ratios = []
        for core in ("transverse", "isotropic"):
            free, held = coarse_runs[core, False, True], coarse_runs[core, True, True]
            ratios.append(f"{core} {held[key]:.0f} against {free[key]:.0f} mm^3 "
                          f"({held[key] / max(free[key], 1e-9):.1f}x), edge lift "
                          f"{held['edge_lift_max_mm']:.2f} against "
                          f"{free['edge_lift_max_mm']:.1f} mm")
        lines += ["", "Crushed volume under the punch with the holder against without: "
                  + "; ".join(ratios) + "."]
        lines += ["", "### Bending of a core strip over the die (`strip_bending`)", "",
                  "| core | cells (x, y, z) | degree | status | punch force [N] "
                  "| beam theory [N] | ratio | Newton/step |", "|---|---|---|---|---|---|---|---|"]
        for core, cells, degree in (("transverse", "15,1,2", 1), ("transverse", "30,1,4", 1),
                                    ("transverse", "60,1,8", 1), ("transverse", "30,1,4", 2),
                                    ("isotropic", "15,1,2", 1), ("isotropic", "60,1,8", 1)):
            s = run_case_process("strip_bending", tmp / f"s{core}{cells}{degree}",
                                 allow_failure=True, sets=(f"elasticity={core}",
                                                           f"cells={cells}", f"degree={degree}"))
            m = s["metrics"]
            lines.append(f"| {core} | {cells} | {degree} | {s['status']} "
                         f"| {m['punch_force_N']:.4f} | {m['beam_theory_force_N']:.4f} "
                         f"| {m['force_over_beam_theory']:.3f} "
                         f"| {s['timing']['newton_per_step']:.1f} |")
    if not quick:
        update_section("hemisphere-transverse", "\n".join(lines),
                       REPO / "docs" / "validation.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main(quick="--quick" in sys.argv[1:])
