"""Meso to macro (issue 20): writes docs/validation.md's ``meso_calibration`` section.

``forming calibrate meso_compression`` on 2 ranks, for the patches of ``--cells``
(default 1 x 1: a few minutes) with fracturing walls to ``--strain``: the meso curve,
the shipped macro curve and the macro ``core_compression`` run with the calibrated
curve on one plot, and the macro run's error against both curves. The runs are kept in
``results/validate_calibration/<cells>`` (a rerun reuses a finished one; delete it to
measure again).

Run: ``python benchmarks/validate_calibration.py [--cells 1,1 3,3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from _report import REPO, machine, update_section

VALIDATION_MD = REPO / "docs" / "validation.md"
FIGURES = REPO / "docs" / "figures"


def calibration(cells: str, strain: float, out: Path) -> tuple[dict, float | None]:
    """The calibration in ``out`` (run on 2 ranks unless it is there) and its wall time."""
    result = out / "calibration.json"
    if result.is_file():
        return json.loads(result.read_text()), None
    mpirun = Path(sys.executable).parent / "mpirun"
    cmd = [str(mpirun), "-n", "2", str(Path(sys.executable).parent / "forming"), "calibrate",
           "meso_compression", "--out", str(out), "--quiet", "--set", f"cells={cells}",
           "--set", f"strain={strain:g}"]
    t0 = time.perf_counter()
    env = dict(os.environ, OMP_NUM_THREADS="1",
               PATH=f"{Path(sys.executable).parent}:{os.environ.get('PATH', '')}")
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, env=env,
                          check=False)
    wall = time.perf_counter() - t0
    if not result.is_file():
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return json.loads(result.read_text()), wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", nargs="+", default=["1,1"])
    parser.add_argument("--strain", type=float, default=0.25)
    args = parser.parse_args()
    root = REPO / "results" / "validate_calibration"
    lines = ["## Meso to macro: `forming calibrate` (issue 20)", "",
             "`forming calibrate meso_compression` runs the meso case (fracturing walls, "
             "bonded platens) and writes its curve as the macro core's C365 curve: put on "
             "the macro core's elastic line until the walls buckle (the first point 0.5% "
             "below it), cut where the crushable foam could not follow it; then the macro "
             "`core_compression` (2 x 2 x 4 elements) runs with that curve and the meso "
             "modulus. `python benchmarks/validate_calibration.py`; 2 ranks; "
             f"{machine()}.", "",
             "| patch | meso run | strain reached | curve points | buckling onset "
             "| modulus [MPa] | largest move before onset | macro vs calibrated curve "
             "(rel. RMS) | macro vs meso curve (rel. RMS) | macro run | G_xz / G_yz [MPa] "
             "| E_x / E_y in plane [MPa] (nu_xy / nu_yx) | wall [s] |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|"]
    figures = []
    for cells in args.cells:
        out = root / cells.replace(",", "x")
        r, wall = calibration(cells, args.strain, out)
        meso = json.loads((out / "meso" / "summary.json").read_text())
        wall = wall if wall is not None else meso["timing"]["wall_s"]
        status = r["meso_status"] + ("" if r["meso_status"] == "completed"
                                     else f" ({meso.get('reason', '')})")
        lines.append(
            f"| {cells} | {status} | {r['meso_strain_reached']:.4f} | {r['points']} "
            f"| {r['buckling_onset_strain']:.4f} | {r['modulus_MPa']:.2f} "
            f"| {100 * r['largest_change_before_onset_rel']:.2f}% "
            f"| {100 * r['check_rmse_rel']:.4f}% | {100 * r['macro_against_meso_rmse_rel']:.3f}% "
            f"| {r['check_status']} | {r['shear_modulus_xz_MPa']:.2f} / "
            f"{r['shear_modulus_yz_MPa']:.2f} | {r['inplane_modulus_x_MPa']:.3f} / "
            f"{r['inplane_modulus_y_MPa']:.3f} ({r['inplane_poisson_x']:.2f} / "
            f"{r['inplane_poisson_y']:.2f}) on {r['tension_cells']} cells | {wall:.0f} |")
        name = f"meso_calibration_{cells.replace(',', 'x')}.png"
        shutil.copy(out / "calibration.png", FIGURES / name)
        figures.append(f"![calibration, {cells} cells](figures/{name})")
    lines += ["", *figures, "",
              "The wall time is the whole command (meso run, curve, macro check, two shear "
              "runs, two in-plane tension runs); a reused run reports its meso run's time. "
              "The macro check takes "
              "seconds. The transverse shear moduli come from the same patch sheared along "
              "x (the ribbon) and y to 0.005 between bonded platens: Gibson and Ashby give "
              "0.577 (t/l) G_s = 5.87 MPa for single-walled regular hexagons, the paper "
              "measured 1.56 MPa (C273), which the macro core keeps; as with the "
              "through-thickness modulus, walls from Table 1 come out stiffer than the "
              "real core. The in-plane moduli come from the same walls pulled along x and y "
              "(on at least 2 x 3 cells; 'Meso in-plane tension' below says which measures "
              "are the lattice's); calibration.json's `core_overrides` gives the macro "
              "core the curve's modulus and the means of the shear and in-plane moduli. "
              "Not yet: a curve to densification (the meso runs stop after the peak)."]
    update_section("meso_calibration", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
