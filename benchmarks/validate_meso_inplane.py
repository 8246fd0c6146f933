"""Meso in-plane tension (issue 20, item 5): writes docs/validation.md's ``meso_inplane``.

``meso_compression --set load=tension_x|tension_y`` (elastic walls, the paper's 20 mm
core, 8 layers, to 0.002 strain in one step) on the default 3 x 3 patch and on 5 x 5
cells, serial, one at a time: the lattice's moduli and Poisson ratios
(:mod:`forming.meso.inplane`) against Gibson and Ashby and the paper's measured
0.2 MPa, the patch's own moduli beside them, and the RVE-size check (3 x 3 against
5 x 5). A ``forming study`` in ``results/validate_meso_inplane`` (a rerun reuses its
runs; delete the folder to measure again).

Run: ``python benchmarks/validate_meso_inplane.py`` (about 5 minutes on 2 cores).
"""

from __future__ import annotations

from _report import REPO, machine, study_runs, update_section

VALIDATION_MD = REPO / "docs" / "validation.md"
SETS = ("strain=0.002", "fracture=false", "max_step=1")


def main() -> None:
    out = REPO / "results" / "validate_meso_inplane"
    pairs = study_runs("meso_compression", {"load": ("tension_x", "tension_y"),
                                            "cells": ("3,3", "5,5")}, out, SETS)
    found: dict[tuple[str, str], dict] = {}
    lines = ["## Meso in-plane tension: the lattice's moduli (issue 20)", "",
             "`meso_compression --set load=tension_x|tension_y` pulls the patch of elastic "
             "walls by its cut faces (20 mm core, 8 layers, 0.002 strain, serial, one run at "
             "a time). Only some of the patch's faces carry the infinite lattice's condition "
             "(`forming/meso/inplane.py`): pulled along x the stress is the reaction on the "
             "inner part of the pulled face, pulled along y the strain is measured from the "
             "inner rows of ribbon walls, and the Poisson ratios come from those walls too. "
             "The patch's own modulus (total force over the whole section, stroke over "
             "length) is given beside it. `python benchmarks/validate_meso_inplane.py`; "
             f"{machine()}.", "",
             "| load | cells | lattice modulus [MPa] | Poisson ratio | Gibson-Ashby modulus "
             "/ Poisson | lattice / Gibson-Ashby | patch modulus [MPa] | status | wall [s] |",
             "|---|---|---:|---:|---:|---:|---:|---|---:|"]
    for _row, s in pairs:
        p, m = s["parameters"], s.get("metrics", {})
        cells = ",".join(str(c) for c in p["cells"])
        found[(p["load"], cells)] = m
        lines.append(
            f"| {p['load']} | {cells} | {m['inplane_modulus_MPa']:.4f} "
            f"| {m['inplane_poisson']:.3f} | {m['gibson_ashby_inplane_MPa']:.4f} / "
            f"{m['gibson_ashby_poisson']:.2f} "
            f"| {m['inplane_modulus_MPa'] / m['gibson_ashby_inplane_MPa']:.3f} "
            f"| {m['patch_modulus_MPa']:.4f} | {s['status']} | {s['timing']['wall_s']:.0f} |")

    def change(load: str, key: str) -> float:
        a, b = found[(load, "3,3")][key], found[(load, "5,5")][key]
        return 100.0 * (b / a - 1.0)

    keys = ("inplane_modulus_MPa", "inplane_poisson", "patch_modulus_MPa")
    parallel = study_runs("meso_compression", {"load": ("tension_x", "tension_y"),
                                                "cells": ("3,3",)}, out / "ranks2", SETS,
                          ranks=2)
    apart = max(abs(s["metrics"][k] / found[(s["parameters"]["load"], "3,3")][k] - 1.0)
                for _row, s in parallel for k in keys)
    ex, ey = (found[(f"tension_{a}", "5,5")]["inplane_modulus_MPa"] for a in "xy")
    lines += [
        "", f"- RVE size: from 3 x 3 to 5 x 5 cells the lattice modulus moves by "
        f"{change('tension_x', 'inplane_modulus_MPa'):+.1f}% along x and "
        f"{change('tension_y', 'inplane_modulus_MPa'):+.1f}% along y, the Poisson ratio by "
        f"{change('tension_x', 'inplane_poisson'):+.1f}% and "
        f"{change('tension_y', 'inplane_poisson'):+.1f}%; the patch's own moduli move by "
        f"{change('tension_x', 'patch_modulus_MPa'):+.1f}% and "
        f"{change('tension_y', 'patch_modulus_MPa'):+.1f}% (its free or held sides).",
        f"- Serial against 2 ranks (`mpirun -n 2`, 3 x 3 cells, both loads): the moduli and "
        f"Poisson ratios agree to {apart:.1e} relative.",
        f"- Isotropy: on 5 x 5 cells E_x / E_y = {ex / ey:.3f}. A regular hexagonal "
        "lattice is isotropic in its plane, and in bending its Poisson ratio is 1 "
        "(Gibson and Ashby).",
        "- Against Gibson and Ashby (walls bending between junction centres, plate modulus "
        "E_s / (1 - nu_s^2)): the meso walls are stiffer, because they bend between "
        "junctions of finite size (single walls 0.3 mm, double ribbon walls 0.6 mm, on 5 mm "
        "walls; a wall's bending compliance goes as its free length cubed).",
        "- Against the paper: its in-plane tests measured 0.2 MPa in both directions, which "
        f"the macro core keeps; the meso lattice gives {ey:.3f} (y) and {ex:.3f} (x) MPa "
        "from Table 1's walls and the estimated cell (docs/materials.md).",
        "- The macro core's transversely isotropic law cannot take a Poisson ratio of 1 "
        "(its in-plane stiffness would not be positive definite): `forming calibrate` "
        "reports it and gives the macro core only the moduli (`core_overrides` in "
        "calibration.json)."]
    update_section("meso_inplane", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
