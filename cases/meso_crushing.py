"""Square-punch crushing of a honeycomb patch whose cell walls are modelled (paper, Fig. 12).

The paper's meso scene: a 120 x 120 x 20 mm cardboard core on a flat plate, an 80 x 80
mm punch with 20 mm fillets crushing it by half its thickness; it found that the walls
buckle and fold under the punch only, crushing starting at the top and running down,
with negligible effect outside the punch. Here the same scene on a patch of ``cells``
honeycomb cells (the walls of ``meso_compression``: quadratic hexahedra, fracture at
Table 1's strain, contact between walls that fold onto each other), scaled to what a
meso run can afford (a stated scaling, as the issue allows): the core ``height`` is half
the paper's (10 mm, 4 layers of elements), the punch covers the middle ``punch`` share
of the patch's width and depth with fillets of ``fillet`` mm (the paper: two thirds,
and a fillet of the core's thickness), and the stroke is half the core, as in the paper.
The walls' bottom edges are held (the plate); the punch touches their top edges, and
their faces once they fold under it (``top_sides``), with the tool-core friction 0.36.

The explicit solver is the default (with mass scaling at the nominal strain rate of
the explicit meso compression runs, docs/validation.md): an implicit run of fracturing
walls stops after the first peak (see ``meso_compression``).

What it gives: the punch force, and where the walls were crushed: the mean settlement
of the wall tops under the punch's flat face and outside the punch, the largest outside,
and the share of the walls' damaged volume that lies outside the punch.

What the default run gives (docs/validation.md, "to the full stroke"; 2 ranks): it
completes the 5 mm stroke. The force peaks at 195 N at 1.2 mm, when the walls under the
punch buckle, then runs at 25-58 N up to 3 mm and 5-47 N after, fold by fold; the wall
tops outside the punch settle 0.03 mm on average for 5 mm of travel. Limits (issue 20):
cells are eroded only once all their points are spent, so some cracked cells stay and
stretch; kinetic energy reaches 18% of the internal energy as walls snap through.

Accuracy of the defaults: not studied (one patch, one mesh).

Run: ``mpirun -n 2 python cases/meso_crushing.py`` (about 50 minutes on a shared 2-core
machine) or ``python cases/meso_crushing.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from mpi4py import MPI

from forming.case import main, require
from forming.contact.shapes import RoundedBox
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.fracture import FracturingSolid
from forming.mesh import bounding_box
from forming.meso import WALL_NEWTON
from forming.meso.honeycomb import (
    WALL_DENSITY,
    HoneycombCell,
    HoneycombPatch,
    honeycomb_mesh,
)
from forming.meso.post import damaged_volume, folded_walls_picture, held_nodes
from forming.scene import Body, Contact, Displacement, Linear, Scene, SelfContact, Tool
from forming.solver.options import ExplicitOptions
from forming.solver.stepping import StepControl

RATE = 62.5  # nominal strain rate of the explicit meso runs [1/s] (docs/validation.md)


@dataclass(frozen=True)
class Params:
    """Parameters of the meso-scale square-punch crushing case (mm, MPa)."""

    cells: tuple[int, ...] = (2, 2)  # cells along x (ribbon) and y
    wall_length: float = 5.0  # inclined wall length l [mm] (estimate, Fig. 3)
    wall_thickness: float = 0.30  # single wall thickness t [mm] (estimate)
    height: float = 10.0  # core thickness [mm] (half the paper's: the stated scaling)
    size: float = 1.2  # in-plane element size [mm] (before the quad split in four)
    layers: int = 4  # elements along the cell axis
    wall_modulus: float = 410.0  # wall Young's modulus [MPa] (Table 1)
    wall_poisson: float = 0.21  # wall Poisson ratio (Table 1)
    fracture_strain: float = 0.067  # wall fracture strain (Table 1)
    fracture_energy: float = 7.4  # wall fracture energy G_f [N/mm] (estimate)
    wall_deletion: Literal["all", "first", "half"] = "all"  # erodes: last point/first/half
    punch: float = 0.5  # punch width over the patch's width (and depth)
    fillet: float = 2.0  # punch edge fillet radius [mm]
    stroke: float = 0.5  # punch travel over the core height (the paper: half)
    friction: float = 0.36  # punch-wall friction (tool-core, stated)
    imperfection: float = 0.05  # largest imperfection move [mm]
    seed: int = 0  # seed of the imperfection
    self_contact: bool = True  # walls touch each other


def build(p: Params) -> Job:
    require(p, positive=("wall_length", "wall_thickness", "height", "size", "wall_modulus",
                         "fracture_strain", "fracture_energy", "fillet"),
            nonnegative=("imperfection", "friction"), fraction=("punch", "stroke"))
    if len(p.cells) != 2:
        raise InputError("--set cells", f"needs two counts (x, y), got {p.cells}")
    cell = HoneycombCell(p.wall_length, None, p.wall_thickness, 30.0, True)
    patch = HoneycombPatch(cell, tuple(p.cells), p.height, p.size / 2, p.layers,
                           p.imperfection, p.seed, False, 0.0, 0.3)
    mesh = honeycomb_mesh(patch)
    lo, hi = bounding_box(mesh.mesh)[:, :2]
    centre, half = (lo + hi) / 2, p.punch * (hi - lo) / 2
    if min(half) <= p.fillet:
        raise InputError("--set fillet", f"{p.fillet:g} mm does not fit a punch of half "
                         f"width {min(half):.3g} mm (raise punch or lower fillet)")
    depth = p.height / 2  # the punch's own half height (it only needs a bottom face)
    shape = RoundedBox((centre[0], centre[1], p.height + depth), (half[0], half[1], depth),
                       p.fillet)
    travel = p.stroke * p.height
    walls = FracturingSolid(IsotropicElasticity(p.wall_modulus, p.wall_poisson),
                            p.fracture_strain, p.fracture_energy, erosion=True,
                            element_deletion=p.wall_deletion, density=WALL_DENSITY)
    scene = Scene(
        name="meso_crushing",
        mesh=mesh,
        bodies=(Body("walls", walls, degree=2),),
        displacements=(Displacement("walls", "bottom", x=0.0, y=0.0, z=0.0),),
        tools=(Tool("punch", shape, z=Linear(-travel)),),
        contacts=(Contact("walls", "top_sides", "punch", friction=p.friction),),
        self_contacts=((SelfContact("walls", "sides", depth=0.5 * p.wall_thickness),)
                       if p.self_contact else ()),
    )
    flat = half - p.fillet  # the punch's flat face, half widths

    def settlement(model) -> dict[str, float]:
        """Wall tops' settlement under the flat face and outside the punch (collective).

        Tops that only eroded cells hold are left out: they float off as fragments.
        """
        body = model.body
        V = body.V
        n = V.dofmap.index_map.size_local
        xr = V.tabulate_dof_coordinates()[:n]
        uz = body.u.x.array.reshape(-1, 3)[:n, 2]
        # the wall tops still held by a live cell (not floating eroded fragments)
        top = (np.abs(xr[:, 2] - p.height) < 1e-6 * p.height) & held_nodes(body)
        off = np.abs(xr[:, :2] - centre)
        inside = top & np.all(off <= flat, axis=1)
        outside = top & np.any(off >= half, axis=1)
        sums = np.array([-uz[inside].sum(), inside.sum(), -uz[outside].sum(), outside.sum()])
        comm = body.mesh.comm
        comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        largest = comm.allreduce(float((-uz[outside]).max(initial=0.0)), op=MPI.MAX)
        return {"settlement_inside_mm": sums[0] / max(sums[1], 1),
                "settlement_outside_mm": sums[2] / max(sums[3], 1),
                "settlement_outside_max_mm": largest}

    def damaged_outside(model) -> float:
        """Share of the walls' damaged volume (damage above 0.5) outside the punch."""
        return damaged_volume(model.body,
                              lambda mid: np.any(np.abs(mid - centre) >= half, axis=1))[1]

    def probe(model) -> dict[str, float]:
        return settlement(model)

    def metrics(rec, model) -> dict:
        f = rec.column("force_punch_z_N")
        out = {"punch_force_max_N": float(np.max(f)), "punch_force_final_N": float(f[-1]),
               "punch_pressure_max_MPa": float(np.max(f)) / float(np.prod(2 * half)),
               "stroke_reached_mm": float(rec.column("t")[-1] * travel),
               **settlement(model),
               "damaged_volume_outside_fraction": damaged_outside(model)}
        return out

    def pictures(model, out: Path) -> list[Path]:
        return folded_walls_picture(model, out, f"Walls after {model.t * travel:.3g} mm "
                                    "of punch travel")

    return Job(
        scene=scene,
        steps=StepControl(initial=0.02, max=0.02, min=1e-5),
        probe=probe, metrics=metrics, pictures=pictures,
        solver="explicit",
        newton=WALL_NEWTON,  # (with --set solver=implicit)
        explicit=ExplicitOptions(loading_time=p.stroke / RATE, target_time_step=2e-7),
        response=Response("force_punch_z_N", travel, 1.0, "punch force"),
    )


if __name__ == "__main__":
    main(build, Params, "meso_crushing")
