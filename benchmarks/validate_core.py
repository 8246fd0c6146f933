"""Virtual core tests against the paper: writes the core section of docs/validation.md.

Runs core_compression (both elasticity options, 1 and 2 ranks), core_shear (C273
specimen length 12 t and 24 t, two meshes each) and core_tension (both directions),
and copies the plots to docs/figures/. Wall times are with warm JIT caches.

Run: ``python benchmarks/validate_core.py``.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, run_case_process, update_section

FIG = REPO / "docs" / "figures"


def main() -> None:
    FIG.mkdir(parents=True, exist_ok=True)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        run_case_process("core_tension", tmp / "warmup")  # JIT caches warm: times are runs
        comp = {}
        for el in ("transverse", "isotropic"):
            comp[el] = run_case_process("core_compression", tmp / f"c_{el}",
                                        sets=(f"elasticity={el}",))
        run_case_process("core_compression", tmp / "c_par", ranks=2)
        h1 = np.genfromtxt(tmp / "c_transverse" / "history.csv", delimiter=",", names=True)
        h2 = np.genfromtxt(tmp / "c_par" / "history.csv", delimiter=",", names=True)
        f1, f2 = h1["reaction_top_z_N"], h2["reaction_top_z_N"]
        par_diff = float(np.max(np.abs(f2 - f1)) / np.max(np.abs(f1)))
        shutil.copy(tmp / "c_transverse" / "stress_strain.png", FIG / "core_compression.png")
        out += [
            "## Core through-thickness compression (ASTM C365), `core_compression`",
            "",
            "![C365 curve](figures/core_compression.png)",
            "",
            "| elasticity | curve RMSE (rel.) | initial modulus [MPa] | peak [MPa] | plateau [MPa] "
            "| stress at 0.90 [MPa] | wall [s] |",
            "|---|---|---|---|---|---|---|",
        ]
        for el, s in comp.items():
            m = s["metrics"]
            out.append(f"| {el} | {m['curve_rmse_rel']:.2e} | {m['initial_modulus_MPa']:.2f} "
                       f"| {m['peak_stress_MPa']:.3f} | {m['plateau_stress_MPa']:.3f} "
                       f"| {m['final_stress_MPa']:.3f} | {s['timing']['wall_s']:.2f} |")
        out += [
            "",
            f"Two ranks against one: largest force difference {par_diff:.1e} of the peak force "
            "(target 1e-6). The paper's macro model reached an RMSE below 5% against its "
            "experiment; here the input is the estimated curve of docs/materials.md, so the "
            "figure checks the model's implementation (curve conversion, return mapping, "
            "finite strain), not the estimate. The block deforms homogeneously between "
            "frictionless platens, so after the first step the extrapolating predictor is "
            "already in equilibrium and Newton takes no iteration.",
            "",
            "## Core shear (ASTM C273), `core_shear`",
            "",
            "Effective modulus from the initial slope, against the measured 1.56 MPa. The free "
            "ends of the specimen lower the effective modulus; the paper's value is itself an "
            "effective C273 figure, the model's input is the intrinsic G = 1.56 MPa.",
            "",
            "| length / thickness | mesh (x, y, z) | G effective [MPa] | error | wall [s] |",
            "|---|---|---|---|---|",
        ]
        for length, meshes in ((240, ("24,2,4", "96,2,16")), (480, ("48,2,4", "96,2,8"))):
            for cells in meshes:
                s = run_case_process("core_shear", tmp / "s", sets=(f"length={length}",
                                                                    f"cells={cells}"))
                g = s["metrics"]["shear_modulus_MPa"]
                out.append(f"| {length / 20:.0f} | {cells} | {g:.4f} | {g / 1.56 - 1:+.2%} "
                           f"| {s['timing']['wall_s']:.1f} |")
        shutil.copy(tmp / "s" / "shear_curve.png", FIG / "core_shear.png")
        out += ["", "The case's default is 24 t with the coarse mesh.", "",
                "## Core in-plane tension, `core_tension`", "",
                "| direction | modulus [MPa] | secant at 0.32 [MPa] | plastic strain | wall [s] |",
                "|---|---|---|---|---|"]
        for d in ("longitudinal", "transverse"):
            s = run_case_process("core_tension", tmp / f"t_{d}", sets=(f"direction={d}",))
            m = s["metrics"]
            out.append(f"| {d} | {m['modulus_MPa']:.4f} | {m['secant_modulus_MPa']:.4f} "
                       f"| {m['max_volumetric_plastic_strain']:.1e} "
                       f"| {s['timing']['wall_s']:.2f} |")
        out += ["", "Paper: 0.2 MPa in both directions up to about 0.32 strain. With the "
                "`biot-hencky` strain measure the nominal response is linear by construction "
                "(docs/theory.md); the yield surface (kt = 0.1) is not reached before 0.32."]
    update_section("core", "\n".join(out), REPO / "docs" / "validation.md")
    print("\n".join(out))


if __name__ == "__main__":
    main()
