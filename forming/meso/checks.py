"""Analytic checks of the thin quadratic walls: bending and buckling against plate theory.

Shared by ``tests/test_meso.py`` (with tolerances) and ``benchmarks/validate_meso.py``
(which writes the numbers into docs/validation.md).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

from forming.materials.elasticity import IsotropicElasticity
from forming.materials.solids import ElasticSolid
from forming.mesh import box
from forming.model import Model
from forming.post.fields import fracture_energy as dissipated_energy
from forming.scene import Body, Displacement, Linear, Scene, Traction
from forming.solver.buckling import buckling_modes
from forming.solver.implicit import ImplicitSolver

WALL_MODULUS, WALL_POISSON = 410.0, 0.21  # the paper's Table 1 (cardboard cell walls)


def wall_model(mesh, displacements, tractions) -> Model:
    """A model of one elastic cardboard wall (Table 1) with quadratic hexahedra."""
    material = ElasticSolid(IsotropicElasticity(WALL_MODULUS, WALL_POISSON))
    return Model(Scene(name="wall", mesh=mesh, bodies=(Body("wall", material, degree=2),),
                       displacements=displacements, tractions=tractions))


def cantilever_ratio(cells: int = 10, length: float = 20.0, width: float = 2.0,
                     thickness: float = 0.3) -> float:
    """Tip deflection of a cantilever strip over beam theory (with shear, kappa = 5/6).

    ``cells`` quadratic hexahedra along, one across and one through the thickness; a
    small tip traction (deflection 0.03 t), free sides.
    """
    load = 1e-5  # MPa on the tip face
    model = wall_model(box((length, width, thickness), (cells, 1, 1)),
                  (Displacement("wall", "xmin", x=0.0, y=0.0, z=0.0, reaction=False),),
                  (Traction("wall", "xmax", z=Linear(-load)),))
    solver = ImplicitSolver(model)
    solver.advance(0.0, 1.0, 0.0)
    if not solver.solve().converged:
        return float("nan")
    body = model.bodies["wall"]
    n = body.V.dofmap.index_map.size_local
    tip = np.isclose(body.V.tabulate_dof_coordinates()[:n, 0], length)
    uz = body.u.x.array.reshape(-1, 3)[:n, 2]
    comm = model.comm
    deflection = -comm.allreduce(float(uz[tip].sum())) / comm.allreduce(int(tip.sum()))
    force, inertia = load * width * thickness, width * thickness**3 / 12
    shear = WALL_MODULUS / (2 * (1 + WALL_POISSON))
    beam = (force * length**3 / (3 * WALL_MODULUS * inertia)
            + force * length / (5 / 6 * shear * width * thickness))
    return deflection / beam


def square_plate(side: float, thickness: float, cells: int) -> Model:
    """A quarter of a simply supported square plate under uniaxial compression (1 MPa).

    Symmetry on ``xmin`` and ``ymin``, the edges ``xmax`` and ``ymax`` held out of plane,
    a dead compressive traction on ``xmax``; ``cells`` x ``cells`` quadratic hexahedra,
    one through the thickness.
    """
    return wall_model(box((side / 2, side / 2, thickness), (cells, cells, 1)),
                      (Displacement("wall", "xmin", x=0.0, reaction=False),
                       Displacement("wall", "ymin", y=0.0, reaction=False),
                       Displacement("wall", "xmax", z=0.0, reaction=False),
                       Displacement("wall", "ymax", z=0.0, reaction=False)),
                      (Traction("wall", "xmax", x=Linear(-1.0)),))


def plate_buckling_ratios(cells: int = 8, side: float = 10.0,
                          thickness: float = 0.2) -> tuple[float, float]:
    """First two buckling stresses of a simply supported square plate over plate theory.

    A quarter with symmetry (``cells`` x ``cells`` quadratic hexahedra, one through the
    thickness) under uniaxial compression; plate theory gives
    ``k pi^2 E / (12 (1 - nu^2)) (t/b)^2`` with ``k = 4`` (one half-wave each way) and
    ``k = (3 + 1/3)^2`` (three half-waves along the load, the next symmetric mode).
    """
    model = square_plate(side, thickness, cells)
    modes = buckling_modes(model, ImplicitSolver(model), n_modes=2)
    plate = math.pi**2 * WALL_MODULUS / (12 * (1 - WALL_POISSON**2)) * (thickness / side) ** 2
    return float(modes.factors[0] / (4.0 * plate)), float(modes.factors[1]
                                                          / ((3 + 1 / 3) ** 2 * plate))


class BandResult(NamedTuple):
    """A crack-band bar pulled apart: its curve and the energy it dissipated."""

    displacement: np.ndarray  # end displacement [mm]
    force: np.ndarray  # end force [N]
    dissipated: float  # energy the damage dissipated, integral of Y dd [N mm]
    expected: float  # max_damage x G_f x cross-section [N mm] (what the law dissipates)
    band: float  # width of the damaged band [mm] (the crack-band width of its points)


def crack_band_bar(out: Path, cells: int, degree: int = 2, length: float = 4.0,
                   side: float = 0.5, fracture_energy: float = 7.4,
                   weakening: float = 0.01, stretch: float = 1.0) -> BandResult:
    """A bar of fracturing cardboard (Table 1, nu 0) pulled until it breaks.

    ``cells`` elements along the bar (odd), one across; the middle element's section is
    ``weakening`` smaller, so the crack starts there. Both ends are held laterally and
    the far end moved ``stretch`` mm: far past the strain at which the band is spent,
    for any ``cells`` the bar must break. Runs through :class:`Simulation` with
    step cutting, in ``out``.
    """
    from forming.job import Job, Response
    from forming.materials.fracture import FracturingSolid
    from forming.simulation import Simulation
    from forming.solver.options import NewtonOptions
    from forming.solver.stepping import StepControl

    if cells % 2 != 1:
        raise ValueError("the bar needs an odd number of cells (one in the middle)")
    mesh = box((length, side, side), (cells, 1, 1), origin=(0.0, -side / 2, -side / 2))
    x = mesh.mesh.geometry.x
    h = length / cells
    middle = np.abs(x[:, 0] - length / 2) <= h / 2 + 1e-9  # the middle element's nodes
    x[middle, 1:] *= 1.0 - weakening
    material = FracturingSolid(IsotropicElasticity(WALL_MODULUS, 0.0),
                               fracture_energy=fracture_energy)
    scene = Scene(name="crack_band", mesh=mesh,
                  bodies=(Body("bar", material, degree=degree),),
                  displacements=(Displacement("bar", "xmin", x=0.0, y=0.0, z=0.0),
                                 Displacement("bar", "xmax", x=Linear(stretch), y=0.0,
                                              z=0.0)))
    job = Job(scene=scene, steps=StepControl(initial=0.004, max=0.004, min=1e-7),
              newton=NewtonOptions(), response=Response("reaction_xmax_x_N", stretch),
              field_every=10**6)
    sim = Simulation(job, out, "crack_band")
    summary = sim.run()
    if summary["status"] != "completed":
        raise RuntimeError(f"crack-band bar ({cells} cells): {summary.get('reason')}")
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    u = np.concatenate([[0.0], hist["t"] * stretch])
    f = np.concatenate([[0.0], hist["reaction_xmax_x_N"]])
    body = sim.model.bodies["bar"]
    bands = body.plastic.ep[:, 1]
    band = sim.model.comm.allreduce(float(bands.max(initial=0.0)), op=MPI.MAX)
    return BandResult(u, f, dissipated_energy(body),
                      material.max_damage * fracture_energy * (side * (1.0 - weakening)) ** 2,
                      band)
