"""Square-punch crushing of a honeycomb core (paper, section "Core crushing", Fig. 12).

A 120 x 120 x 20 mm macro-model core lies on a flat rigid plate; an 80 x 80 mm punch with
20 mm fillets crushes it by 10 mm (half the thickness). Quarter model (x, y >= 0) with
symmetry planes; figures are for the whole specimen. The paper's findings: crushing
starts under the punch and runs through the thickness, with negligible effect outside
the punch and negligible in-plane draw-in of the core edge.

The shipped core curve softens after its peak (0.40 to 0.25 MPa); without regularisation
Newton stalls there, as the crushing localises. A small viscous regularisation
(``viscosity``, 0.03 MPa mm by default, docs/theory.md) carries it through; the eta study in
docs/validation.md measures what it adds to the force. ``gap`` starts the punch above the
core (first contact inside a load step).

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): the
mean force over 2-10 mm (``punch_force_mean_N``) changes by 3.3% on the 12 x 12 x 9 mesh,
which takes 7 times the wall time; the peak force is 9% below its Richardson value (order
1.1). On 2 ranks repeated runs of the same settings spread by 2% in peak and 1.5% in mean
force (round-off decides which layer crushes first).

Run: ``python cases/core_crushing.py`` or ``mpirun -n 2 python cases/core_crushing.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import ufl

from forming import post
from forming.case import main, require
from forming.contact.shapes import Plane, RoundedBox
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.partition import mesh_partition
from forming.scene import Body, Contact, Displacement, Linear, Scene, Tool
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

TOOL_CORE_FRICTION = 0.36  # paper, section "Friction between materials"


@dataclass(frozen=True)
class Params:
    """Parameters of the square-punch crushing case (mm)."""

    size: float = 120.0  # core side [mm] (paper: 120)
    thickness: float = 20.0  # core thickness [mm] (paper: 20)
    punch: float = 80.0  # punch side [mm] (paper: 80)
    fillet: float = 20.0  # punch edge fillet radius [mm] (paper: 20)
    stroke: float = 10.0  # punch travel into the core [mm] (paper: 10)
    gap: float = 0.0  # initial clearance above the core [mm]; the punch travels gap + stroke
    friction: float = TOOL_CORE_FRICTION  # tool-core Coulomb coefficient (paper: 0.36)
    cells: tuple[int, ...] = (8, 8, 6)  # elements along x, y, z of the quarter model
    elasticity: Literal["transverse", "isotropic"] = "transverse"  # core elasticity
    curve: str | None = None  # C365 curve CSV; none: shipped estimate
    viscosity: float = 0.03  # viscous regularisation [MPa mm] (docs/theory.md)
    max_step: float = 0.1  # largest load step (fraction of the stroke)
    linear_solver: Literal["auto", "mumps", "mumps_blr", "gamg"] = "auto"  # linear solver
    partition: Literal["auto", "graph", "wedge"] = "auto"  # ranks' cells; auto: wedge if explicit


def build(p: Params) -> Job:
    require(p, positive=("size", "thickness", "punch", "stroke"),
            nonnegative=("gap", "friction", "fillet"))
    if p.punch > p.size or p.stroke >= p.thickness:
        raise InputError("--set punch" if p.punch > p.size else "--set stroke",
                         "the punch must fit the core and the stroke stay below its thickness")
    half, h = p.size / 2, p.thickness
    mesh = box((half, half, h), tuple(p.cells), partition=mesh_partition(p.partition))
    tall = 100.0
    punch = RoundedBox((0.0, 0.0, h + p.gap + tall), (p.punch / 2, p.punch / 2, tall), p.fillet)
    scene = Scene(
        name="core_crushing", mesh=mesh,
        bodies=(Body("core", honeycomb_core(p.elasticity, curve=p.curve,
                                           viscosity=p.viscosity)),),
        displacements=(Displacement("core", "xmin", x=0.0, reaction=False),
                       Displacement("core", "ymin", y=0.0, reaction=False)),
        tools=(Tool("punch", punch, z=Linear(-(p.stroke + p.gap))),
               Tool("plate", Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)))),
        contacts=(Contact("core", "top", "punch", friction=p.friction),
                  Contact("core", "bottom", "plate", friction=p.friction)),
        symmetry_copies=4,
    )
    def metrics(rec, model) -> dict:
        evp = post.plastic_field(model.body)
        x = ufl.SpatialCoordinate(model.body.mesh)
        outside = ufl.conditional(ufl.Or(ufl.gt(x[0], p.punch / 2), ufl.gt(x[1], p.punch / 2)),
                                  1.0, 0.0)
        flat = p.punch / 2 - p.fillet
        under = ufl.conditional(ufl.And(ufl.lt(x[0], flat), ufl.lt(x[1], flat)), 1.0, 0.0)
        evp_max = post.plastic_strain_max(model.body)
        # mean over 2 mm to the end (benchmarks/validate_crushing.py): it converges
        return post.force_peak_final(rec, "force_punch_z_N") | post.force_mean(
            rec, "force_punch_z_N", 2.0 / (p.stroke + p.gap)) | {
            "crushed_volume_mm3": post.crushed_volume(model),
            "crushed_volume_fraction": evp.crushed_volume() / (half * half * h),
            "crushing_depth_mm": post.crushing_depth(evp, under, h),
            "mean_plastic_strain_under_punch": evp.mean(under),
            "mean_plastic_strain_outside_punch": evp.mean(outside),
            "edge_draw_in_mm": post.edge_draw_in(model.body, half, half),
            # volumetric plastic (log) strain, and as a nominal strain 1 - exp(-evp)
            "crushing_strain_max": evp_max,
            "crushing_strain_max_nominal": 1.0 - float(np.exp(-evp_max)),
        } | post.contact_metrics(rec, model)

    def plots(rec, out: Path) -> list[Path]:
        return post.punch_force_plot(rec, out, p.stroke + p.gap, "Square-punch crushing",
                                     scene.symmetry_copies)

    return Job(scene=scene, steps=StepControl(initial=min(0.05, p.max_step), max=p.max_step),
               newton=NewtonOptions(linear_solver=p.linear_solver, line_search="bt"),
               probe=post.crushed_volume_probe, metrics=metrics, plots=plots,
               response=Response("force_punch_z_N", p.stroke + p.gap, label="punch force"),
               pictures=lambda model, out: post.plastic_strain_pictures(
                   model, out, "ymin", "Core crushing", tools_3d=("punch",)))


if __name__ == "__main__":
    main(build, Params, "core_crushing")
