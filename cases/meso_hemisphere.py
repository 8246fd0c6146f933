"""Hemisphere forming of a honeycomb patch whose cell walls are modelled (paper, Figs. 10-11).

The paper's "Core bending" scene at the meso scale: a core on a die with a round
opening, formed by a hemispherical punch, with or without a blank holder
(``--set blank_holder=true``). The paper (macro scale, 300 x 300 x 20 mm core, punch
100 mm, die opening 144 mm, 50 mm stroke) found that without a holder the core conforms
mainly by bending, with little crushing, and that the holder makes crushing under the
punch grow.

Stated scaling: the tools, the core's thickness and the stroke are the paper's times
``scale`` (0.15 by default: a 3 mm core, a 15 mm punch, a 21.6 mm die opening with
1.5 mm edge radii, 7.5 mm of full stroke, of which the share ``stroke`` is run: half by
default, 3.75 mm, more than the core's thickness), while the cells keep their real size
(wall length 5 mm, ``meso_compression``'s walls: quadratic hexahedra, Table 1's
cardboard, fracture at 0.067 with element erosion). The patch of ``cells`` cells (5 x 4,
37.5 x 34.6 mm, by default) is about the paper's blank over die ratio. The cells are
therefore 1/``scale`` times larger against the part than the paper's: the punch spans
about two cells, not twelve, and the 3 mm walls are squat (height over wall length 0.6,
the paper's 4). What survives that scaling is the mechanism the paper reads off, bending
against crushing, not its forces. The whole patch is modelled (a quarter model needs two
of the lattice's mirror planes as cuts; the mesher cuts one pair of sides through the
inclined walls' middles, which is not one), and nothing holds it but the tools and their
friction (tool-core 0.36).

The punch meets the walls' top edges and their faces (``top_sides``), the die and the
holder the bottom and top edges and faces (``bottom_sides``, ``top_sides``); walls that
fold onto each other touch (self-contact). Explicit solver, with the macro
``hemisphere``'s explicit loading times scaled by ``scale`` (structural periods scale
with size) and mass scaling to ``target_time_step``; the run reports the kinetic over
internal energy.

What it gives, beside the punch force: the core's compaction (one minus the current
over the initial thickness, the distance between a wall's top and bottom nodes) under
the punch's cap and on the flange, the flange's largest lift off the die (bending), the
walls' damaged volume and its share under the punch (crushing), side by side with the
macro ``hemisphere`` at the same scaled geometry in docs/validation.md
(``benchmarks/validate_meso_hemisphere.py``).

What the defaults give (docs/validation.md): the paper's mechanism. Without the holder
the flange lifts 3.4 mm off the die and the core's compaction under the punch is 0.15;
with it the flange stays down (0.02 mm) and the compaction is 0.27. Limits (issue 20):
mass scaling adds 86-117 times the walls' mass and the kinetic energy reaches 55-118% of
the internal energy, so the forces carry inertia; read the shapes, not the forces.

Run: ``mpirun -n 2 python cases/meso_hemisphere.py [--set blank_holder=true]`` (about 70
minutes on one core with the holder, about twice that without it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from forming.case import main, require
from forming.contact.shapes import AnnularPlate, HemisphericalPunch
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.fracture import FracturingSolid
from forming.mesh import bounding_box
from forming.meso import WALL_NEWTON
from forming.meso.honeycomb import WALL_DENSITY, HoneycombCell, HoneycombPatch, honeycomb_mesh
from forming.meso.post import damaged_volume, folded_walls_picture, wall_columns
from forming.post.metrics import force_peak_final
from forming.scene import Body, Contact, Linear, Scene, SelfContact, Tool
from forming.solver.options import ExplicitOptions
from forming.solver.stepping import StepControl

# the paper's scene (mm): core thickness, punch and die diameters, edge radii, stroke
PAPER = {"height": 20.0, "punch": 100.0, "die": 144.0, "edge": 10.0, "stroke": 50.0}
# macro hemisphere's explicit loading times [s] (cases/hemisphere.py): holder, free
LOADING_TIME = {True: 0.05, False: 0.1}


@dataclass(frozen=True)
class Params:
    """Parameters of the meso-scale hemisphere forming case (mm, MPa)."""

    blank_holder: bool = False  # clamp the flange with a blank holder
    scale: float = 0.15  # tools, core thickness and stroke over the paper's
    cells: tuple[int, ...] = (5, 4)  # cells along x (ribbon) and y
    wall_length: float = 5.0  # inclined wall length l [mm] (estimate, Fig. 3)
    wall_thickness: float = 0.30  # single wall thickness t [mm] (estimate)
    size: float = 2.0  # in-plane element size [mm] (before the quad split in four)
    layers: int = 2  # elements along the cell axis
    wall_modulus: float = 410.0  # wall Young's modulus [MPa] (Table 1)
    wall_poisson: float = 0.21  # wall Poisson ratio (Table 1)
    fracture_strain: float = 0.067  # wall fracture strain (Table 1)
    fracture_energy: float = 7.4  # wall fracture energy G_f [N/mm] (estimate)
    wall_deletion: Literal["all", "first", "half"] = "all"  # erodes: last point/first/half
    friction: float = 0.36  # tool-core friction (stated)
    stroke: float = 0.5  # share of the scaled stroke run (1: the paper's full stroke)
    imperfection: float = 0.05  # largest imperfection move [mm]
    seed: int = 0  # seed of the imperfection
    self_contact: bool = True  # walls touch each other
    target_time_step: float = 3e-7  # explicit time step reached by mass scaling [s]


def build(p: Params) -> Job:
    require(p, positive=("scale", "wall_length", "wall_thickness", "size", "wall_modulus",
                         "fracture_strain", "fracture_energy", "target_time_step", "stroke"),
            nonnegative=("imperfection", "friction"))
    if p.stroke > 1.0:
        raise InputError("--set stroke", f"is a share of the scaled stroke, at most 1, got "
                         f"{p.stroke:g}")
    if len(p.cells) != 2:
        raise InputError("--set cells", f"needs two counts (x, y), got {p.cells}")
    height = p.scale * PAPER["height"]
    radius, hole = p.scale * PAPER["punch"] / 2, p.scale * PAPER["die"] / 2
    edge, travel = p.scale * PAPER["edge"], p.stroke * p.scale * PAPER["stroke"]
    cell = HoneycombCell(p.wall_length, None, p.wall_thickness, 30.0, True)
    patch = HoneycombPatch(cell, tuple(p.cells), height, p.size / 2, p.layers,
                           p.imperfection, p.seed, False, 0.0, 0.3)
    mesh = honeycomb_mesh(patch)
    lo, hi = bounding_box(mesh.mesh)[:, :2]
    centre = (lo + hi) / 2
    if min(hi - lo) / 2 <= hole + edge:
        raise InputError("--set cells", f"a {hi[0] - lo[0]:.3g} x {hi[1] - lo[1]:.3g} mm "
                         f"patch does not cover the die opening of radius {hole + edge:.3g} "
                         "mm and its edge (more cells or a smaller scale)")
    cx, cy = float(centre[0]), float(centre[1])
    tools = [Tool("punch", HemisphericalPunch((cx, cy, height), radius, length=4 * height),
                  z=Linear(-travel)),
             Tool("die", AnnularPlate((cx, cy, 0.0), hole, edge, side=-1))]
    contacts = [Contact("walls", "top_sides", "punch", friction=p.friction),
                Contact("walls", "bottom_sides", "die", friction=p.friction)]
    if p.blank_holder:
        tools.append(Tool("holder", AnnularPlate((cx, cy, height), hole, edge, side=1)))
        contacts.append(Contact("walls", "top_sides", "holder", friction=p.friction))
    walls = FracturingSolid(IsotropicElasticity(p.wall_modulus, p.wall_poisson),
                            p.fracture_strain, p.fracture_energy, erosion=True,
                            element_deletion=p.wall_deletion, density=WALL_DENSITY)
    scene = Scene(
        name="meso_hemisphere", mesh=mesh, bodies=(Body("walls", walls, degree=2),),
        tools=tuple(tools), contacts=tuple(contacts),
        self_contacts=((SelfContact("walls", "sides", depth=0.5 * p.wall_thickness),)
                       if p.self_contact else ()))

    def shape(model) -> dict[str, float]:
        """Compaction under the cap and on the flange, and the flange's lift (collective)."""
        xy, top, bottom = wall_columns(model.body, height)
        r = np.hypot(xy[:, 0] - cx, xy[:, 1] - cy)
        compaction = 1.0 - (top - bottom) / height
        cap, flange = r < 0.7 * radius, r > hole + edge
        return {"compaction_mean_under_punch": float(compaction[cap].mean()),
                "compaction_max": float(compaction.max()),
                "compaction_mean_flange": float(compaction[flange].mean()),
                "flange_lift_max_mm": float(bottom[flange].max())}

    def damage(model) -> dict[str, float]:
        """Walls' volume with damage above 0.5: its share of the walls, and under the punch."""
        share, under = damaged_volume(
            model.body, lambda mid: np.hypot(mid[:, 0] - cx, mid[:, 1] - cy) < radius)
        return {"damaged_volume_fraction": share, "damaged_under_punch_fraction": under}

    def metrics(rec, model) -> dict:
        return force_peak_final(rec, "force_punch_z_N") | shape(model) | damage(model) | {
            "stroke_reached_mm": float(rec.column("t")[-1] * travel)}

    def pictures(model, out: Path) -> list[Path]:
        return folded_walls_picture(model, out, f"Walls after {model.t * travel:.3g} mm of "
                                    "punch travel" + (", holder" if p.blank_holder else ""))

    return Job(
        scene=scene, steps=StepControl(initial=0.05, max=0.05, min=1e-5),
        probe=shape, metrics=metrics, pictures=pictures, solver="explicit",
        newton=WALL_NEWTON,  # (with --set solver=implicit)
        explicit=ExplicitOptions(loading_time=p.stroke * p.scale
                                 * LOADING_TIME[p.blank_holder],
                                 target_time_step=p.target_time_step),
        response=Response("force_punch_z_N", travel, 1.0, "punch force"))


if __name__ == "__main__":
    main(build, Params, "meso_hemisphere")
