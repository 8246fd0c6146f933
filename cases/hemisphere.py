"""Hemisphere forming of a honeycomb core (paper, section "Core bending", Figs. 10-11).

A 300 x 300 x 20 mm core on a die with a 144 mm opening is formed by a 100 mm
hemispherical punch over a 50 mm stroke, tool-core friction 0.36, with or without a
blank holder (``--set blank_holder=true``). Quarter model with symmetry planes; figures
are for the whole core. The paper's finding: without a blank holder the core conforms
mainly by bending with little crushing; with one, crushing under the punch increases.

The die and holder edge radii are not given in the paper: 10 mm is an estimate. The core
defaults to isotropic elasticity, the crushable-foam form the paper used in Abaqus: with
the transversely isotropic law (0.2 MPa in-plane) Newton does not yet converge under
the curved punch (issue #3). The shipped curve softens after its peak; a small viscous
regularisation (``viscosity``, 0.003 MPa) lets Newton follow the crushing, within about 2%
of the extrapolated rate-independent force (docs/validation.md).

Run: ``python cases/hemisphere.py --set blank_holder=true``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import ufl
from mpi4py import MPI

from forming.case import main
from forming.contact.shapes import AnnularPlate, HemisphericalPunch
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.post import (
    contact_metrics,
    plastic_field,
    plastic_strain_pictures,
    punch_force_plot,
)
from forming.run import Job
from forming.scene import Body, Contact, Displacement, Linear, Scene, Tool
from forming.solver.implicit import NewtonOptions
from forming.solver.stepping import StepControl

TOOL_CORE_FRICTION = 0.36  # paper, section "Friction between materials"


@dataclass(frozen=True)
class Params:
    """Parameters of the hemisphere forming case (mm)."""

    blank_holder: bool = False
    size: float = 300.0
    thickness: float = 20.0
    punch_diameter: float = 100.0
    die_diameter: float = 144.0
    edge_radius: float = 10.0  # estimate: not stated in the paper
    stroke: float = 50.0
    friction: float = TOOL_CORE_FRICTION
    cells: tuple[int, ...] = (20, 20, 4)
    grading: float = 1.08
    elasticity: Literal["transverse", "isotropic"] = "isotropic"
    curve: str | None = None
    viscosity: float = 0.003  # MPa: viscous regularisation (docs/validation.md, eta study)
    max_step: float = 0.01
    min_step: float = 1e-4
    linear_solver: Literal["mumps", "gamg"] = "mumps"


def build(p: Params) -> Job:
    half, h = p.size / 2, p.thickness
    mesh = box((half, half, h), tuple(p.cells), grading=(p.grading, p.grading, 1.0))
    R = p.punch_diameter / 2
    hole = p.die_diameter / 2
    tools = [Tool("punch", HemisphericalPunch((0.0, 0.0, h), R, length=150.0),
                  z=Linear(-p.stroke)),
             Tool("die", AnnularPlate((0.0, 0.0, 0.0), hole, p.edge_radius, side=-1))]
    contacts = [Contact("core", "top", "punch", friction=p.friction),
                Contact("core", "bottom", "die", friction=p.friction)]
    if p.blank_holder:
        tools.append(Tool("holder", AnnularPlate((0.0, 0.0, h), hole, p.edge_radius, side=1)))
        contacts.append(Contact("core", "top", "holder", friction=p.friction))
    scene = Scene(
        name="hemisphere", mesh=mesh,
        bodies=(Body("core", honeycomb_core(p.elasticity, curve=p.curve,
                                                          viscosity=p.viscosity)),),
        displacements=(Displacement("core", "xmin", x=0.0, reaction=False),
                       Displacement("core", "ymin", y=0.0, reaction=False)),
        tools=tuple(tools), contacts=tuple(contacts),
    )

    def probe(model) -> dict[str, float]:
        return {"crushed_volume_mm3": 4 * plastic_field(model.body).crushed_volume()}

    def metrics(rec, model) -> dict:
        evp = plastic_field(model.body)
        x = ufl.SpatialCoordinate(model.body.mesh)
        under = ufl.conditional(ufl.lt(x[0] ** 2 + x[1] ** 2, R**2), 1.0, 0.0)
        body = model.body
        comm = model.comm
        cell_evp = body.cell_average(body.plastic.evp)
        u = body.u.x.array.reshape(-1, 3)
        xs = body.V.tabulate_dof_coordinates()[: body.V.dofmap.index_map.size_local]
        uo = u[: xs.shape[0]]
        edge = np.isclose(xs[:, 0], half) | np.isclose(xs[:, 1], half)
        edge_lift = comm.allreduce(float(np.abs(uo[edge, 2]).max(initial=0.0)), op=MPI.MAX)
        # conformity: gap between the core's top and the punch over the punch's cap
        punch = model.contacts[0]
        punch._gap.interpolate(punch._gap_expr, cells0=punch._cells)
        g = punch._gap.x.array[punch._owned]
        r = np.linalg.norm(punch._gap.function_space.tabulate_dof_coordinates()
                           [punch._owned][:, :2], axis=1)
        cap = r < 0.7 * R
        gap_max = comm.allreduce(float(g[cap].max(initial=0.0)), op=MPI.MAX)
        crushing = ufl.max_value(evp.evp, 0.0)  # compaction; negative evp is dilation
        force = 4 * rec.column("force_punch_z_N")
        return {
            "punch_force_max_N": float(force.max()),
            "crushed_volume_mm3": 4 * evp.crushed_volume(),
            "crushed_volume_under_punch_mm3": 4 * evp.crushed_volume(0.01, under),
            "crushing_strain_mean_under_punch": evp.integral(crushing * under)
            / evp.integral(under),
            "crushing_strain_max": comm.allreduce(float(cell_evp.max(initial=0.0)), op=MPI.MAX),
            "dilation_strain_max": -comm.allreduce(float(cell_evp.min(initial=0.0)),
                                                   op=MPI.MIN),
            "edge_lift_max_mm": edge_lift,
            "punch_gap_max_mm": gap_max,
        } | contact_metrics(rec, model)

    def plots(rec, out: Path) -> list[Path]:
        title = "Hemisphere forming" + (" with blank holder" if p.blank_holder else "")
        return punch_force_plot(rec, out, p.stroke, title)

    return Job(scene=scene, steps=StepControl(initial=min(0.02, p.max_step), max=p.max_step,
                                 min=min(p.min_step, p.max_step)),
               newton=NewtonOptions(linear_solver=p.linear_solver, line_search="bt"),
               probe=probe, metrics=metrics, plots=plots, field_every=5,
               pictures=lambda model, out: plastic_strain_pictures(
                   model, out, "ymin", "Hemisphere" + (" + holder" if p.blank_holder else ""),
                   tools_3d=("punch",)))


if __name__ == "__main__":
    main(build, Params, "hemisphere")
