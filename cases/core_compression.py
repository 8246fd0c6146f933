"""ASTM C365 through-thickness compression of a macro-model honeycomb core block.

A block between frictionless platens is crushed to 0.90 nominal strain. The computed
nominal stress-strain curve must reproduce the input C365 curve (relative RMS error
below 1%) with its linear region, plateau and densification.

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): a
homogeneous test: the curve error is the same on 1 x 1 x 2 to 4 x 4 x 8 meshes.

Run: ``python cases/core_compression.py`` or ``mpirun -n 2 python cases/core_compression.py``
or ``forming run core_compression --set elasticity=isotropic``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from forming import post
from forming.case import main, require
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.output import plot_curves
from forming.scene import Body, Displacement, Linear, Scene
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl


@dataclass(frozen=True)
class Params:
    """Parameters of the C365 compression case (mm, MPa)."""

    width: float = 50.0  # specimen side [mm]
    thickness: float = 20.0  # core thickness [mm]
    cells: tuple[int, ...] = (2, 2, 4)  # elements along x, y, z
    strain: float = 0.9  # nominal strain reached (0 < strain < 1)
    elasticity: Literal["transverse", "isotropic"] = "transverse"  # core elasticity
    curve: str | None = None  # C365 curve CSV; none: shipped estimate
    modulus: float | None = None  # through-thickness modulus [MPa]; none: shipped (15)
    elastic_band: float = 0.05  # curve points this close to the elastic line are on it
    max_step: float = 0.05  # largest load step (fraction of the stroke)
    linear_solver: Literal["auto", "mumps", "mumps_blr", "gamg"] = "auto"  # linear solver
    extrapolate: bool = False  # allow strains past the curve's last point


def build(p: Params) -> Job:
    require(p, positive=("width", "thickness", "modulus"), fraction=("strain",))
    modulus = {} if p.modulus is None else {
        "E_through" if p.elasticity == "transverse" else "E": p.modulus}
    material = honeycomb_core(p.elasticity, curve=p.curve, elastic_band=p.elastic_band,
                              **modulus)
    if p.strain > material.curve.strain[-1] and not p.extrapolate:
        raise InputError("--set strain", f"{p.strain:g} passes the last point of the curve "
                         f"({material.curve.strain[-1]:g}, {material.curve.source}); give a "
                         "longer curve, or --set extrapolate=true")
    mesh = box((p.width, p.width, p.thickness), tuple(p.cells))
    area = p.width**2
    stroke = p.strain * p.thickness
    scene = Scene(
        name="core_compression",
        mesh=mesh,
        bodies=(Body("core", material),),
        displacements=(
            Displacement("core", "bottom", z=0.0, reaction=False),
            Displacement("core", "top", z=Linear(-stroke)),
            Displacement("core", "xmin", x=0.0, reaction=False),
            Displacement("core", "ymin", y=0.0, reaction=False),
        ),
    )
    curve = material.curve
    # land on every point of the input curve so the comparison includes all of them
    stops = tuple(e / p.strain for e in curve.strain[1:] if 0 < e < p.strain)

    def nominal(rec) -> tuple[np.ndarray, np.ndarray]:
        e = rec.column("t") * p.strain
        s = -rec.column("reaction_top_z_N") / area
        return e, s

    def metrics(rec, model) -> dict:
        e, s = nominal(rec)
        ref = curve.interpolate(e)
        at_data = np.isin(np.round(e, 10), np.round(np.asarray(curve.strain), 10))
        plateau = (e > 0.1) & (e < 0.6)
        return {
            "curve_rmse_rel": post.relative_rms(s, ref),
            "curve_rmse_rel_at_data_points": post.relative_rms(s[at_data], ref[at_data]),
            "initial_modulus_MPa": float(s[1] / e[1]) if len(e) > 1 else float("nan"),
            "peak_stress_MPa": float(s[e < 0.1].max()),
            "plateau_stress_MPa": float(s[plateau].mean()) if plateau.any() else float("nan"),
            "final_strain": float(e[-1]),
            "final_stress_MPa": float(s[-1]),
            "max_volumetric_plastic_strain": post.plastic_strain_max(model.body),
        }

    def plots(rec, out: Path) -> list[Path]:
        e, s = nominal(rec)
        grid = np.linspace(0, min(p.strain, curve.strain[-1]), 400)  # the data, not beyond
        return [plot_curves(
            out / "stress_strain.png",
            [(grid, curve.interpolate(grid), f"input curve ({Path(curve.source).name})", "k-"),
             (e, s, "computed (forming)", "o")],
            "nominal strain", "nominal stress [MPa]", "Core through-thickness compression",
        )]

    return Job(
        scene=scene,
        steps=StepControl(initial=0.01, max=p.max_step, min=1e-5, stops=stops),
        newton=NewtonOptions(linear_solver=p.linear_solver),
        metrics=metrics, plots=plots,
        response=Response("reaction_top_z_N", stroke, -1.0, "platen force"),
        limits=(("curve_rmse_rel", 0.01),),  # the virtual test reproduces its input
    )


if __name__ == "__main__":
    main(build, Params, "core_compression")
