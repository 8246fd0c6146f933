"""Hemisphere forming of a honeycomb core (paper, section "Core bending", Figs. 10-11).

A 300 x 300 x 20 mm core on a die with a 144 mm opening is formed by a 100 mm
hemispherical punch over a 50 mm stroke, tool-core friction 0.36, with or without a
blank holder (``--set blank_holder=true``). Quarter model; figures are for the whole
core. The paper's finding: without a holder the core conforms mainly by bending with
little crushing; with one, crushing under the punch increases. The die and holder edge
radii (10 mm) are estimates. The core is isotropic by default (the paper's Abaqus form);
``--set elasticity=transverse`` takes the measured moduli (15 MPa through the thickness,
0.2 MPa in-plane, 1.56 MPa transverse shear). A small viscous regularisation
(``viscosity``, 0.15 MPa mm) lets Newton follow the softening curve, within about 2% of the
rate-independent force (docs/validation.md).

Contact numerics (``tool_stick``; ``newton.line_search`` overrides the line search that
follows it): Coulomb friction with elastic slip (stick stiffness proportional to the
pressure) and full Newton steps by default. Every variant has contact nodes at almost zero
pressure (a flange clamped by the holder, a transverse core hinging over the die edge,
skins on the tools), where the augmented stick constraint (``tool_stick=augmented``, with
backtracking) makes them stick and slip from one Newton iteration to the next: the
transverse core stalls in its first step (docs/theory.md, section 13), the isotropic core
takes 2 to 4 times the iterations.

``--set skins=true``: the full sandwich, a core between two FCIM359 NCF skins (+/-45 deg,
0.4 mm per ply) sliding on the core (0.52) and on the tools (0.23); the metrics add each
skin's shear range, the area beyond the wrinkling angles (+42 / -50 deg) and the slip.
``--set tools=stl`` (or ``step``): the same tools as surface meshes, built with
OpenCASCADE and written under ``meshes/generated/tools`` on first use; ``tool_angle``
sets their tessellation (docs/validation.md, tools from surface meshes).
With skins, by default (``skin_contact=finite``) the skins are meshed apart from the core
(``skin_refinement`` elements per core element) and slide on it any distance (node to
surface, docs/theory.md section 11), with the skin-core pressure's kink smoothed
(``skin_smoothing``, 0.1 there) and PETSc's ``l2`` line search; the default mesh then
completes the stroke with and without the holder. ``--set skin_contact=small``: the
cheaper node-to-node pairing of one conforming mesh, valid while the slip stays below
half an element (it warns beyond; on the default mesh with the holder it stops at
40.5 mm).
Accuracy of the defaults with skins and holder (docs/validation.md, "Convergence of the
shipped cases"): the largest top-skin shear is 0.2% from its Richardson value; the punch
force changes by 5% from the 16 x 16 x 4 mesh and by 11% when the load step halves, the
crushed volume by up to 40% (the core crushes along another path): read the shear as
converged, the force to about 10%. Halving the step costs 1.4 times the wall time on the
12 x 12 x 3 mesh; the 16 to 20 mesh step cost 1.5 times.

Run: ``python cases/hemisphere.py --set blank_holder=true`` (add ``skins=true``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

from forming import post
from forming.blanks import SKINS, Skins, rectangular_blank
from forming.cad import Tessellation
from forming.case import main, require
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.fabric import NonCrimpFabric
from forming.materials.library import honeycomb_core
from forming.partition import mesh_partition
from forming.scene import Scene
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl
from forming.tooling import hemisphere_tools

TOOL_CORE_FRICTION = 0.36  # paper, section "Friction between materials"
FABRIC_CORE_FRICTION = 0.52
TOOL_FABRIC_FRICTION = 0.23


@dataclass(frozen=True)
class Params:
    """Parameters of the hemisphere forming case (mm)."""

    blank_holder: bool = False  # clamp the flange with a blank holder
    size: float = 300.0  # blank side [mm] (paper: 300)
    thickness: float = 20.0  # core thickness [mm] (paper: 20)
    punch_diameter: float = 100.0  # punch diameter [mm] (paper: 100)
    die_diameter: float = 144.0  # die opening [mm] (paper: 144)
    edge_radius: float = 10.0  # die and holder edge radius [mm] (estimate)
    stroke: float = 50.0  # punch travel [mm] (paper: 50)
    friction: float = TOOL_CORE_FRICTION  # tool-core Coulomb coefficient (paper: 0.36)
    cells: tuple[int, ...] = (20, 20, 4)  # elements along x, y and through the core (quarter model)
    grading: float = 1.08  # in-plane element growth away from the centre (core alone)
    elasticity: Literal["transverse", "isotropic"] = "isotropic"  # core elasticity
    curve: str | None = None  # C365 curve CSV; none: shipped estimate
    viscosity: float = 0.15  # viscous regularisation [MPa mm] (docs/theory.md)
    max_step: float = 0.01  # largest load step (fraction of the stroke)
    min_step: float = 1e-4  # smallest load step
    linear_solver: Literal["auto", "mumps", "mumps_blr", "gamg"] = "auto"  # linear solver
    skins: bool = False  # the sandwich: NCF skins on both faces, sliding on the core
    plies: int = 1  # plies per skin
    skin_thickness: float = 0.4  # ply thickness [mm]
    skin_friction: float = FABRIC_CORE_FRICTION  # skin-core Coulomb coefficient (paper: 0.52)
    tool_skin_friction: float = TOOL_FABRIC_FRICTION  # tool-skin Coulomb coefficient (paper: 0.23)
    skin_stabilisation: float = 1e-4  # interface stabilisation, fraction of its penalty
    skin_smoothing: float | None = None  # smoothed skin-core pressure ramp; none: see below
    tool_stick: Literal["auto", "augmented", "elastic_slip"] = "auto"  # tool stick law
    tool_penalty: float | None = None  # tool contact penalty [N/mm^3]; none: 10 C_max / h
    skin_contact: Literal["small", "finite"] = "finite"  # skins on the core: finite or small
    skin_refinement: int = 1  # finite sliding: skin elements per core element in plane
    skin_transfer: Literal["area", "point"] = "area"  # finite sliding: skin force onto the core
    tools: Literal["analytic", "stl", "step"] = "analytic"  # tools: formulas or surface meshes
    tool_angle: float = 5.0  # surface-mesh tools: largest angle per triangle on curved faces [deg]
    tool_max_size: float = 25.0  # surface-mesh tools: largest triangle on flat faces [mm]
    partition: Literal["auto", "graph", "wedge"] = "auto"  # ranks' cells; auto: wedge if explicit


def contact_numerics(p: Params) -> tuple[str, str]:
    """The tool stick law (resolving ``auto``) and the Newton line search of the run.

    ``auto`` is Coulomb friction with elastic slip (a stick stiffness proportional to the
    pressure), and the line search follows the stick law: full Newton steps with elastic
    slip, backtracking with the augmented stick constraint; ``--set
    newton.line_search=...`` (every case's Newton setting) overrides it. Nodes at almost
    zero pressure are in every variant: the skins touch the tools and the core at zero
    pressure, a transversely isotropic core (in-plane modulus 0.2 MPa) hinges over the die
    edge, and a blank holder clamps the flange between two tools. With the augmented
    stick constraint such nodes stuck and slipped from one Newton iteration to the next:
    the transverse core stalled in its first step (docs/theory.md, section 13), and the
    isotropic core took 1,378 Newton iterations on the default mesh with the holder
    (148 s) against 379 (42 s) with elastic slip, 788 against 438 without it
    (docs/performance.md). Skins sliding finitely take PETSc's ``l2`` line search: on the
    default mesh without a holder, full steps cut back 10 times and stopped at 47.3 mm,
    ``l2`` cut back 3 times and completed (docs/theory.md, section 11).
    """
    stick = "elastic_slip" if p.tool_stick == "auto" else p.tool_stick
    if p.skins and p.skin_contact == "finite":
        return stick, "l2"
    return stick, "basic" if stick == "elastic_slip" else "bt"


def skin_smoothing(p: Params) -> float:
    """The skin-core pressure ramp's smoothing (``skin_smoothing``, or its default).

    Finite sliding: 0.1 of the tolerance's pressure. Without it the nodes at almost zero
    pressure switched between open and closed from one Newton iteration to the next and
    the default mesh without holder stopped at 1.75 mm; with it, the same run went on to
    47 mm, and to the end with the ``l2`` line search (:func:`contact_numerics`;
    docs/theory.md, section 11). Small sliding: 0 (its validated figures).
    """
    if p.skin_smoothing is not None:
        return p.skin_smoothing
    return 0.1 if p.skin_contact == "finite" else 0.0


def build(p: Params) -> Job:
    require(p, positive=("size", "thickness", "punch_diameter", "die_diameter", "stroke")
            + (("tool_penalty",) if p.tool_penalty is not None else ()),
            nonnegative=("friction", "edge_radius", "skin_friction", "tool_skin_friction",
                         "skin_stabilisation")
            + (("skin_smoothing",) if p.skin_smoothing is not None else ()))
    if p.punch_diameter >= p.die_diameter:
        raise InputError("--set punch_diameter", f"{p.punch_diameter:g} mm does not pass the "
                         f"{p.die_diameter:g} mm die opening")
    half, R = p.size / 2, p.punch_diameter / 2
    skins = Skins(NonCrimpFabric(thickness=p.skin_thickness), p.plies, p.skin_friction,
                  p.skin_stabilisation, skin_smoothing(p), p.skin_contact,
                  p.skin_refinement, p.skin_transfer) if p.skins else None
    b = rectangular_blank(half, half, p.thickness, p.cells, honeycomb_core(
        p.elasticity, curve=p.curve, viscosity=p.viscosity), skins, p.grading,
        mesh_partition(p.partition))
    stick, search = contact_numerics(p)
    tools, contacts = hemisphere_tools(
        b, p.punch_diameter, p.die_diameter, p.edge_radius, p.stroke,
        p.tool_skin_friction if p.skins else p.friction, p.blank_holder, stick,
        p.tools, Tessellation(p.tool_angle, p.tool_max_size))
    if p.tool_penalty is not None:
        contacts = tuple(replace(c, penalty=p.tool_penalty) for c in contacts)
    scene = Scene(name="hemisphere", mesh=b.mesh, bodies=b.bodies, displacements=b.symmetry(),
                  tools=tools, contacts=contacts, interfaces=b.interfaces, sliding=b.sliding,
                  symmetry_copies=4)
    title = "Hemisphere" + (" + holder" if p.blank_holder else "")

    def metrics(rec, model) -> dict:
        return post.hemisphere_metrics(rec, model, R, half) | (
            post.skin_shear_statistics(model, SKINS) | post.interface_slips(model)
            if p.skins else {})

    def pictures(model, out: Path) -> list[Path]:
        section = b.face("core", "ymin") if b.prefixed else (
            "core_edge_ymin" if p.skins else "ymin")
        pngs = post.plastic_strain_pictures(model, out, section, title, tools_3d=("punch",))
        if p.skins:
            pngs += post.shear_angle_picture(model, out, f"{title}: top skin shear angle [deg]",
                                             "shear_angle_skin_top.png", body_name="skin_top")
        return pngs

    def plots(rec, out: Path) -> list[Path]:
        title = "Hemisphere forming" + (" with blank holder" if p.blank_holder else "")
        return post.punch_force_plot(rec, out, p.stroke, title, scene.symmetry_copies)

    return Job(scene=scene, steps=StepControl(initial=min(0.02, p.max_step), max=p.max_step,
                                              min=min(p.min_step, p.max_step)),
               # full Newton steps where nodes sit at zero pressure: backtracking on the
               # residual norm crawled through their open/closed and stick/slip switches
               newton=NewtonOptions(linear_solver=p.linear_solver, line_search=search),
               # without a holder the blank first bends freely with little internal energy:
               # over 0.05 s its kinetic energy reached 11.7% of the internal energy
               # (docs/validation.md, explicit defaults)
               explicit=ExplicitOptions(loading_time=0.05 if p.blank_holder else 0.1),
               probe=post.crushed_volume_probe, metrics=metrics, plots=plots, field_every=5,
               pictures=pictures,
               response=Response("force_punch_z_N", p.stroke, label="punch force"))


if __name__ == "__main__":
    main(build, Params, "hemisphere")
