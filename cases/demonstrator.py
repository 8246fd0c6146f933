"""The demonstrator: a flat sandwich blank pressed between matched tools into a curved part.

The paper's application (sections "Demonstrator forming simulation" to "Forming-induced
defects", Figs. 13-16). Its component is not published, so the shipped part is our own
in its spirit (docs/theory.md, section 16; :mod:`forming.demonstrator.geometry`): a
600 x 480 mm dished panel, 30 mm deep with a doubly curved bottom, formed from a
720 x 590 mm blank of a 20 mm C365 core between two +/-45 deg FCIM359 plies. The matched
tools crush the core to 7 mm on the flange and to 8 mm in two pads on the dish bottom;
the tool radii are 20-60 mm. Friction: tool-fabric 0.23, fabric-core 0.52 (paper). The
lower tool is fixed; the upper one closes along -z from just above the blank. Quarter
model (the part is symmetric about x = 0 and y = 0).

The case forms any matched pair: ``--set lower_tool=FILE --set upper_tool=FILE`` (STEP,
IGES, STL, OBJ, ...; closed solids in their closed position, in mm or with
``tool_scale``), ``--set blank=FILE`` (the blank's outline, symmetric about both axes:
a CSV of x, y points or a DXF file with one closed outline), ``--set trim=FILE`` (the
finished part's outline, CSV or DXF), and the
core thickness, plies and fibre angles. The shipped tools are written on first use under
``meshes/generated/demonstrator-*`` by ``python meshes/demonstrator_tools.py``.

Outputs, besides the usual: each skin's shear map with the wrinkling limits (+42 / -50
deg), the conformity map (gap between each skin and its tool at the end; bridged area
where it exceeds ``bridging_gap``), the core's thickness and crushing maps, a section
through y = 0 (tools, skins and core with the crushing strain), the blank edge's
draw-in and the closing force against the stroke.

Implicit numerics: the skins slide on the core with stabilising springs (10^-3 of the
penalty) that carry Newton through each step; each converged step is then solved again
with the springs at a tenth (``newton.spring_release``), which takes most of their drag
out of the answer (docs/theory.md, section 16). The explicit cross-check on the 60 mm
mesh (``forming compare demonstrator --set element_size=60``) is then within 1.5% of
the core's thickness in shape and 2% in force (docs/validation.md).

Run: ``python cases/demonstrator.py`` (``mpirun -n 2`` works the same).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from forming import post
from forming.blanks import Skins, outline_blank
from forming.case import main, require
from forming.demonstrator import setup
from forming.demonstrator.report import Report
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.fabric import NonCrimpFabric
from forming.materials.library import honeycomb_core
from forming.scene import Scene
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl

TOOL_FABRIC_FRICTION = 0.23  # paper, section "Friction between materials"
FABRIC_CORE_FRICTION = 0.52


@dataclass(frozen=True)
class Params:
    """Parameters of the demonstrator forming case (mm)."""

    lower_tool: str | None = None  # lower tool file, closed position; none: shipped part
    upper_tool: str | None = None  # upper tool file, closed position; none: shipped part
    tool_scale: float = 1.0  # factor from the tool files' units to mm
    blank: str | None = None  # blank outline, CSV (x, y) or DXF; none: 720 x 590 rectangle
    trim: str | None = None  # trim line, CSV (x, y) or DXF; none: the shipped part's
    core_thickness: float = 20.0  # core thickness [mm] (paper: 20)
    plies: int = 1  # plies per skin (paper: one)
    ply_thickness: float = 0.4  # ply thickness [mm]
    fibre_angles: tuple[float, ...] = (45.0, -45.0)  # fibre directions from x [deg]
    tool_friction: float = TOOL_FABRIC_FRICTION  # tool-skin Coulomb coefficient (paper: 0.23)
    skin_friction: float = FABRIC_CORE_FRICTION  # skin-core Coulomb coefficient (paper: 0.52)
    element_size: float = 30.0  # core element size in plan [mm]
    core_layers: int = 2  # core elements through the thickness
    skin_refinement: int = 1  # skin elements per core element in plan
    skin_stabilisation: float = 1e-3  # skin-core stabilising spring, fraction of the penalty
    skin_elastic_slip: float = 1.5e-3  # skin-core stick slip at the limit, of the edge (implicit)
    clearance: float = 0.0  # gap between the open upper tool and the blank [mm]; > 0 floats it
    contact_tolerance: float | None = None  # skin-tool penetration allowed [mm]; none: 1% ply
    tool_penalty_scale: float = 10.0  # skin-tool penalty over the default 10 E / h (implicit)
    bridging_gap: float = 0.5  # a skin farther than this from its tool is bridging [mm]
    curve: str | None = None  # C365 curve CSV; none: shipped estimate
    viscosity: float = 0.15  # core viscous regularisation [MPa mm]
    max_step: float = 0.01  # largest load step (fraction of the stroke)
    min_step: float = 1e-4  # smallest load step
    linear_solver: Literal["auto", "mumps", "mumps_blr", "gamg"] = "auto"  # linear solver


def build(p: Params) -> Job:
    require(p, positive=("tool_scale", "core_thickness", "ply_thickness", "element_size",
                         "bridging_gap", "tool_penalty_scale", "skin_elastic_slip"),
            nonnegative=("tool_friction", "skin_friction", "clearance", "skin_stabilisation"))
    require(p, positive=("contact_tolerance",) if p.contact_tolerance is not None else ())
    if len(p.fibre_angles) != 2:
        raise InputError("--set fibre_angles", f"two angles, got {p.fibre_angles}")
    part = setup.Part.from_params(p.lower_tool, p.upper_tool, p.tool_scale, p.blank, p.trim,
                                  p.core_thickness + 2 * p.plies * p.ply_thickness)
    fabric = NonCrimpFabric(thickness=p.ply_thickness, fibre_angles_deg=tuple(p.fibre_angles))
    skins = Skins(fabric, p.plies, p.skin_friction, p.skin_stabilisation, 0.1, "finite",
                  p.skin_refinement, elastic_slip=p.skin_elastic_slip)
    b = outline_blank(part.quarter, p.core_thickness, p.element_size, p.core_layers,
                      honeycomb_core("isotropic", curve=p.curve, viscosity=p.viscosity), skins)
    tools, contacts, stroke = setup.matched_tools(part, b, p.tool_friction, p.clearance,
                                                  p.contact_tolerance, p.tool_penalty_scale)
    scene = Scene(name="demonstrator", mesh=b.mesh, bodies=b.bodies,
                  displacements=b.symmetry(), tools=tools, contacts=contacts,
                  sliding=b.sliding, symmetry_copies=4)
    report = Report(part, b, stroke, p.bridging_gap, p.core_thickness,
                    fabric.critical_angles_deg)
    return Job(scene=scene, steps=StepControl(initial=min(0.02, p.max_step), max=p.max_step,
                                              min=min(p.min_step, p.max_step)),
               # full Newton steps: the l2 line search of the hemisphere with sliding
               # skins took partial steps that converged linearly (first step cut back 4
               # times, contact states chattering later) and made serial and 2-rank runs
               # part (docs/theory.md, 16); a step that needs more than 20 iterations is
               # cheaper cut back (section 16); each converged step is solved again with
               # the skin-core springs at a tenth, which takes most of their drag out of
               # the answer (section 16)
               newton=NewtonOptions(linear_solver=p.linear_solver, line_search="basic",
                                    max_it=20, spring_release=0.1),
               # the skins drape into the lower tool before anything presses them: over
               # 0.05 s their kinetic energy reached 18% of the internal there (section 16)
               explicit=ExplicitOptions(loading_time=0.1),
               probe=post.crushed_volume_probe, metrics=report.metrics, plots=report.plots,
               pictures=report.pictures, field_every=5,
               response=Response("force_upper_z_N", stroke, label="closing force"),
               cautions=_cautions(p))


def _cautions(p: Params) -> tuple[str, ...]:
    """What the settings make of the answer."""
    if p.clearance > 0:
        # docs/validation.md, "Serial against 2 ranks"
        return (f"clearance = {p.clearance:g} mm: until the upper tool touches it, the "
                "blank is held by nothing along z and Newton leaves it where the linear "
                "solves' round-off puts it, so the step path (and the end force, to about "
                "1e-3) depends on the number of ranks and on the run",)
    return ()


if __name__ == "__main__":
    main(build, Params, "demonstrator")
