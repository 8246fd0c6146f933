"""Square-punch crushing of a honeycomb core (paper, section "Core crushing", Fig. 12).

A 120 x 120 x 20 mm macro-model core lies on a flat rigid plate; an 80 x 80 mm punch with
20 mm fillets crushes it by 10 mm (half the thickness). Quarter model (x, y >= 0) with
symmetry planes; figures are for the whole specimen. The paper's findings: crushing
starts under the punch and runs through the thickness, with negligible effect outside
the punch and negligible in-plane draw-in of the core edge.

The shipped core curve softens after its peak (0.40 to 0.25 MPa); without regularisation
Newton stalls there, as the crushing localises. A small viscous regularisation
(``viscosity``, 0.003 MPa by default, docs/theory.md) carries it through; the eta study in
docs/validation.md measures what it adds to the force. ``gap`` starts the punch above the
core (first contact inside a load step).

Run: ``python cases/core_crushing.py`` or ``mpirun -n 2 python cases/core_crushing.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import ufl
from mpi4py import MPI

from forming.case import main
from forming.contact.shapes import Plane, RoundedBox
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.post import (
    contact_metrics,
    plastic_field,
    plastic_strain_pictures,
    punch_force_plot,
)
from forming.scene import Body, Contact, Displacement, Linear, Scene, Tool
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

TOOL_CORE_FRICTION = 0.36  # paper, section "Friction between materials"


@dataclass(frozen=True)
class Params:
    """Parameters of the square-punch crushing case (mm)."""

    size: float = 120.0
    thickness: float = 20.0
    punch: float = 80.0
    fillet: float = 20.0
    stroke: float = 10.0
    gap: float = 0.0  # initial clearance between punch and core; the punch travels gap + stroke
    friction: float = TOOL_CORE_FRICTION
    cells: tuple[int, ...] = (8, 8, 6)
    elasticity: Literal["transverse", "isotropic"] = "transverse"
    curve: str | None = None
    viscosity: float = 0.003  # MPa: viscous regularisation (docs/validation.md, eta study)
    max_step: float = 0.1
    linear_solver: Literal["mumps", "gamg"] = "mumps"


def build(p: Params) -> Job:
    half, h = p.size / 2, p.thickness
    mesh = box((half, half, h), tuple(p.cells))
    tall = 100.0
    if p.gap < 0:
        raise InputError("gap", f"must be >= 0 (initial clearance), got {p.gap}")
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
    def probe(model) -> dict[str, float]:
        return {"crushed_volume_mm3": 4 * plastic_field(model.body).crushed_volume()}

    def metrics(rec, model) -> dict:
        evp = plastic_field(model.body)
        x = ufl.SpatialCoordinate(model.body.mesh)
        outside = ufl.conditional(ufl.Or(ufl.gt(x[0], p.punch / 2), ufl.gt(x[1], p.punch / 2)),
                                  1.0, 0.0)
        flat = p.punch / 2 - p.fillet
        under = ufl.conditional(ufl.And(ufl.lt(x[0], flat), ufl.lt(x[1], flat)), 1.0, 0.0)
        # crushing depth: through-thickness extent of crushed material under the punch flat
        from dolfinx import fem  # after forming: PETSc comes from dolfinx_solver

        depth = 0.0
        level = fem.Constant(model.body.mesh, 0.0)
        band = under * ufl.conditional(ufl.lt(x[2], level), 0.0, 1.0)
        for z0 in np.linspace(0.0, h, 41):
            level.value = z0
            if evp.crushed_volume(0.01, band) >= 0.5 * evp.integral(band):
                depth = h - z0
                break
        body = model.body
        u = body.u.x.array.reshape(-1, 3)
        xs = body.V.tabulate_dof_coordinates()
        edge_x = np.isclose(xs[:, 0], half)
        edge_y = np.isclose(xs[:, 1], half)
        draw_in = max(float(-u[edge_x, 0].min(initial=0.0)), float(-u[edge_y, 1].min(initial=0.0)))
        draw_in = model.comm.allreduce(draw_in, op=MPI.MAX)
        force = rec.column("force_punch_z_N") * 4
        evp_max = model.comm.allreduce(float(body.plastic.evp.max(initial=0.0)),
                                       op=MPI.MAX)
        return {
            "punch_force_max_N": float(force.max()),
            "punch_force_final_N": float(force[-1]),
            "crushed_volume_mm3": 4 * evp.crushed_volume(),
            "crushed_volume_fraction": evp.crushed_volume() / (half * half * h),
            "crushing_depth_mm": depth,
            "mean_plastic_strain_under_punch": evp.mean(under),
            "mean_plastic_strain_outside_punch": evp.mean(outside),
            "edge_draw_in_mm": draw_in,
            # volumetric plastic (log) strain, and as a nominal strain 1 - exp(-evp)
            "crushing_strain_max": evp_max,
            "crushing_strain_max_nominal": 1.0 - float(np.exp(-evp_max)),
        } | contact_metrics(rec, model)

    def plots(rec, out: Path) -> list[Path]:
        return punch_force_plot(rec, out, p.stroke + p.gap, "Square-punch crushing")

    return Job(scene=scene, steps=StepControl(initial=min(0.05, p.max_step), max=p.max_step),
               newton=NewtonOptions(linear_solver=p.linear_solver, line_search="bt"),
               probe=probe, metrics=metrics, plots=plots,
               response=Response("force_punch_z_N", p.stroke + p.gap, label="punch force"),
               pictures=lambda model, out: plastic_strain_pictures(
                   model, out, "ymin", "Core crushing", tools_3d=("punch",)))


if __name__ == "__main__":
    main(build, Params, "core_crushing")
