"""Square-punch crushing (`core_crushing`): writes docs/validation.md's crushing section.

1. The default run (8 x 8 x 6 quarter mesh, eta = 0.03 MPa mm), serial and on 2 ranks: the
   paper's metrics and the section PNG.
2. The viscous regularisation's effect (6 x 6 x 4 mesh): eta from 0.2 MPa mm down to 0.
   The punch force of a crushing core oscillates as layers of elements collapse one after
   another, so the table gives the peak and the mean force over 2-10 mm of stroke; the
   mean is extrapolated to eta = 0 by a least-squares line through every converged eta.
   A ``forming study`` in ``results/validate_crushing/eta`` (a rerun reuses its runs).

Run: ``python benchmarks/validate_crushing.py`` (about 15 minutes on 2 cores).
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, run_case_process, study_runs, update_section

ETAS = (0.2, 0.1, 0.05, 0.03, 0.02, 0.0)  # MPa mm (per mm of the 10 mm stroke)


def main() -> None:
    lines = ["## Square-punch crushing, `core_crushing` (issue #3)", "",
             "Quarter model, transversely isotropic core with the shipped C365 estimate "
             "(peak 0.40 MPa, plateau 0.25 MPa), friction 0.36, 10 mm stroke. "
             "`python benchmarks/validate_crushing.py`.", "",
             "| mesh | ranks | status | punch force max [N] | mean force 2-10 mm [N] "
             "| crushed volume [mm^3] | crushing depth [mm] | plastic strain under / outside "
             "punch | edge draw-in [mm] | penetration / tolerance [mm] | Newton/step "
             "| wall [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for ranks in (1, 2):
            out = tmp / f"default{ranks}"
            s = run_case_process("core_crushing", out, ranks, allow_failure=True)
            m = s["metrics"]
            lines.append(
                f"| 8,8,6 | {ranks} | {s['status']} | {m['punch_force_max_N']:.0f} "
                f"| {m['punch_force_mean_N']:.0f} | {m['crushed_volume_mm3']:.0f} "
                f"| {m['crushing_depth_mm']:.1f} "
                f"| {m['mean_plastic_strain_under_punch']:.3f} / "
                f"{m['mean_plastic_strain_outside_punch']:.4f} | {m['edge_draw_in_mm']:.2f} "
                f"| {m['max_penetration_mm']:.3f} / {m['penetration_tolerance_mm']:.3f} "
                f"| {s['timing']['newton_per_step']:.1f} | {s['timing']['wall_s']:.0f} |")
            if ranks == 1:
                for png in ("section_plastic_strain.png", "punch_force.png"):
                    if (out / png).exists():
                        shutil.copy(out / png, REPO / "docs" / "figures" / f"core_crushing_{png}")
        lines += ["", "![section](figures/core_crushing_section_plastic_strain.png)",
                  "![punch force](figures/core_crushing_punch_force.png)", "",
                  "### Viscous regularisation: what eta adds (6 x 6 x 4 mesh)", "",
                  "| eta [MPa mm] | status | stroke [mm] | punch force max [N] "
                  "| mean force 2-10 mm [N] | mean vs eta -> 0 | crushed volume [mm^3] "
                  "| Newton/step | wall [s] |",
                  "|---|---|---|---|---|---|---|---|---|"]
        study = [(float(row.values["viscosity"]), s,
                  s["metrics"]["punch_force_mean_N"] if row.status == "completed" else None)
                 for row, s in study_runs("core_crushing", {"viscosity": ETAS},
                                          REPO / "results" / "validate_crushing" / "eta",
                                          ("cells=6,6,4", "max_step=0.05"))]
        done = sorted((e, f) for e, s, f in study if f is not None)
        exact = next((f for e, f in done if e == 0.0), None)
        if exact is None and len(done) >= 2:
            # least-squares line through every converged eta: the mean force still carries
            # a few percent of noise from layers collapsing one at a time
            slope, exact = np.polyfit([e for e, _ in done], [f for _, f in done], 1)
        for eta, s, mean in study:
            m = s["metrics"]
            err = f"{mean / exact - 1:+.1%}" if exact and mean is not None else "-"
            lines.append(f"| {eta} | {s['status']} | {10 * s['load_parameter_reached']:.2f} "
                         f"| {m['punch_force_max_N']:.0f} "
                         f"| {'-' if mean is None else f'{mean:.0f}'} | {err} "
                         f"| {m['crushed_volume_mm3']:.0f} "
                         f"| {s['timing']['newton_per_step']:.1f} "
                         f"| {s['timing']['wall_s']:.0f} |")
        if exact:
            lines.append(f"| -> 0 | | | | {exact:.0f} | reference (least-squares line) "
                         "| | | |")
    lines += ["", "Serial against 2 ranks: two ranks add the element contributions in another "
              "order, so the Newton iterates differ by round-off, and Newton stops anywhere "
              "within its force tolerance (force_rtol = 1e-4 of the largest force). A step "
              "that needs a cut-back on one rank count may pass on the other; from there the "
              "step paths differ, and on the softening curve the forces differ by about the "
              "tolerance (the two rows above). Where the paths agree the forces agree to "
              "round-off: `tests/test_parallel.py` runs the full stroke on 4 x 4 x 2 and holds "
              "them to 1e-8 of the peak on the common path, and the peak, final force and "
              "crushed volume to 1% whatever the path. On 2 ranks the path is not even the "
              "same from one run to the next: the parallel sums' round-off differs between "
              "runs, and four 2-rank runs of the defaults gave peak forces of 1673, 1703, "
              "1705 and 1706 N (docs/validation.md, convergence of the shipped cases). The "
              "serial run repeats to every printed digit."]
    lines += ["", "Without regularisation (eta = 0) Newton stalls where the layers under the "
              "punch pass the curve's peak together (the discrete problem bifurcates); the "
              "viscous term (docs/theory.md) selects one path. Its overstress grows with "
              "eta: the default 0.03 MPa mm is chosen from this table. The peak force is "
              "noisy (single layers collapsing); the mean force is the converging quantity."]
    update_section("crushing", "\n".join(lines), REPO / "docs" / "validation.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
