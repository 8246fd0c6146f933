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

With ``--set skins=true`` the blank is the full sandwich: the core between a bottom and a
top skin of FCIM359 non-crimp fabric (+/-45 deg, 0.4 mm per ply), each skin its own body
sliding on the core (friction 0.52, separation allowed) and on the tools (0.23). The
metrics add the shear-angle range of each skin, the area fraction beyond the wrinkling
angles (+42 / -50 deg) and the skin-core slip; ``shear_angle_skin_top.png`` maps the top
skin's shear.

Run: ``python cases/hemisphere.py --set blank_holder=true`` (add ``skins=true``).
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
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.fabric import NonCrimpFabric
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.post import (
    contact_metrics,
    plastic_field,
    plastic_strain_pictures,
    punch_force_plot,
    shear_angle_picture,
)
from forming.sandwich import Outline, sandwich_blank
from forming.scene import Body, Contact, Displacement, Interface, Linear, Scene, Tool
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

TOOL_CORE_FRICTION = 0.36  # paper, section "Friction between materials"
FABRIC_CORE_FRICTION = 0.52
TOOL_FABRIC_FRICTION = 0.23


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
    skins: bool = False
    plies: int = 1
    skin_thickness: float = 0.4
    skin_friction: float = FABRIC_CORE_FRICTION
    tool_skin_friction: float = TOOL_FABRIC_FRICTION
    skin_stabilisation: float = 1e-3  # fraction of the interface penalty (docs/theory.md)
    skin_smoothing: float = 0.0  # smoothed interface pressure ramp (docs/theory.md)


def build(p: Params) -> Job:
    half, h = p.size / 2, p.thickness
    core = honeycomb_core(p.elasticity, curve=p.curve, viscosity=p.viscosity)
    if p.skins:
        if p.cells[0] != p.cells[1]:
            raise InputError("cells", f"with skins the in-plane mesh is square: got {p.cells}")
        mesh = sandwich_blank(Outline.rectangle(half, half), core_thickness=h,
                              skin_thickness=p.skin_thickness, plies=p.plies,
                              element_size=half / p.cells[0], core_layers=p.cells[2])
        top, bottom = h + 2 * p.plies * p.skin_thickness, 0.0
        fabric = NonCrimpFabric(thickness=p.skin_thickness)
        bodies = (Body("core", core, region="core"),
                  Body("skin_bottom", fabric, region="skin_bottom"),
                  Body("skin_top", fabric, region="skin_top"))
        upper, lower, mu = "skin_top", "skin_bottom", p.tool_skin_friction
        interfaces = tuple(Interface(f"interface_{side}", "core", f"skin_{side}",
                                     friction=p.skin_friction,
                                     stabilisation=p.skin_stabilisation,
                                     smoothing=p.skin_smoothing)
                           for side in ("bottom", "top"))
    else:
        mesh = box((half, half, h), tuple(p.cells), grading=(p.grading, p.grading, 1.0))
        top, bottom = h, 0.0
        bodies = (Body("core", core),)
        upper = lower = "core"
        mu = p.friction
        interfaces = ()
    R = p.punch_diameter / 2
    hole = p.die_diameter / 2
    tools = [Tool("punch", HemisphericalPunch((0.0, 0.0, top), R, length=150.0),
                  z=Linear(-p.stroke)),
             Tool("die", AnnularPlate((0.0, 0.0, bottom), hole, p.edge_radius, side=-1))]
    # fabric on a tool: the same elastic-slip stick as on the core (nodes under the
    # holder touch at zero pressure, where an augmented stick constraint cycled)
    stick = "elastic_slip" if p.skins else "augmented"
    contacts = [Contact(upper, "top", "punch", friction=mu, stick=stick),
                Contact(lower, "bottom", "die", friction=mu, stick=stick)]
    if p.blank_holder:
        tools.append(Tool("holder", AnnularPlate((0.0, 0.0, top), hole, p.edge_radius,
                                                 side=1)))
        contacts.append(Contact(upper, "top", "holder", friction=mu, stick=stick))
    symmetry = tuple(d for b in bodies for d in (
        Displacement(b.name, "xmin", x=0.0, reaction=False),
        Displacement(b.name, "ymin", y=0.0, reaction=False)))
    scene = Scene(
        name="hemisphere", mesh=mesh, bodies=bodies, displacements=symmetry,
        tools=tuple(tools), contacts=tuple(contacts), interfaces=interfaces,
        symmetry_copies=4,
    )
    section = "core_edge_ymin" if p.skins else "ymin"

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
        g, xg = model.contacts[0].nodal_gap()
        r = np.linalg.norm(xg[:, :2], axis=1)
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
        } | contact_metrics(rec, model) | (skin_metrics(model) if p.skins else {})

    def skin_metrics(model) -> dict:
        out: dict = {}
        lo_all, hi_all, wrinkled = np.inf, -np.inf, 0.0
        for name in ("skin_bottom", "skin_top"):
            body = model.bodies[name]
            body.update_output()
            lo, hi = body.shear_range_deg()
            frac = body.wrinkle_area_fraction()
            out |= {f"shear_min_deg_{name}": lo, f"shear_max_deg_{name}": hi,
                    f"wrinkle_area_fraction_{name}": frac}
            lo_all, hi_all = min(lo_all, lo), max(hi_all, hi)
            wrinkled = max(wrinkled, frac)
        slips = {f"skin_core_slip_max_mm_{itf.spec.other}": itf.max_slip()
                 for itf in model.interfaces}
        return {"shear_min_deg": lo_all, "shear_max_deg": hi_all,
                "wrinkle_area_fraction": wrinkled,
                "skin_core_slip_max_mm": max(slips.values())} | out | slips

    def pictures(model, out: Path) -> list[Path]:
        title = "Hemisphere" + (" + holder" if p.blank_holder else "")
        pngs = plastic_strain_pictures(model, out, section, title, tools_3d=("punch",))
        if p.skins:
            pngs += shear_angle_picture(model, out, f"{title}: top skin shear angle [deg]",
                                        "shear_angle_skin_top.png", body_name="skin_top")
        return pngs

    def plots(rec, out: Path) -> list[Path]:
        title = "Hemisphere forming" + (" with blank holder" if p.blank_holder else "")
        return punch_force_plot(rec, out, p.stroke, title)

    return Job(scene=scene, steps=StepControl(initial=min(0.02, p.max_step), max=p.max_step,
                                 min=min(p.min_step, p.max_step)),
               # with skins, full Newton steps: at the first touch every interface node sits
               # at zero pressure, and backtracking crawled through the open/closed switches
               newton=NewtonOptions(linear_solver=p.linear_solver,
                                    line_search="basic" if p.skins else "bt"),
               probe=probe, metrics=metrics, plots=plots, field_every=5,
               pictures=pictures,
               response=Response("force_punch_z_N", p.stroke, label="punch force"))


if __name__ == "__main__":
    main(build, Params, "hemisphere")
