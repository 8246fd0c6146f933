"""Contact patch test: two blocks meshed apart pass a uniform pressure across their interface.

Taylor & Papadopoulos (1991): an upper block pressed onto a lower one by a uniform
pressure, the interface's meshes not matching (``upper_cells`` against ``lower_cells``
elements along each side), both blocks of the same elastic material on rollers (x held on
the ``xmin`` faces, y on the ``ymin`` faces, z on the lower block's bottom), so that the
exact solution is a uniform stress in both and a uniform contact pressure equal to the
applied one. Frictionless finite sliding (docs/theory.md, section 11), the upper block's
bottom the slave side.

A node-to-surface contact that puts each slave node's force on the master at one point
(``--set transfer=point``) fails this test: the master receives the slave's nodal forces
at the wrong weights and passes the pressure on unevenly. Spreading each node's force over
its tributary area (``transfer=area``, the default) passes it to the accuracy of its
quadrature. ``metrics.pressure_deviation_max`` is the largest ``|p / p_applied - 1|``
over the slave nodes.

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): the
slave pressure stays within 0.5% of 1 MPa with 3, 5 and 9 slave elements.

Run: ``python cases/contact_patch.py`` (``--set upper_cells=3`` puts a coarse slave on a
finer master).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from forming.case import main, require
from forming.job import Job
from forming.materials import ElasticSolid, IsotropicElasticity
from forming.mesh import Block, blocks
from forming.scene import Body, Displacement, Linear, Scene, Sliding, Traction
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

SIDE, HEIGHT = 40.0, 10.0  # each block [mm]


@dataclass(frozen=True)
class Params:
    """Parameters of the contact patch test (mm, MPa)."""

    pressure: float = 1.0  # applied on the upper block's top [MPa]
    lower_cells: int = 4  # lower block (master) elements along x and y
    upper_cells: int = 5  # upper block (slave) elements along x and y
    modulus: float = 100.0  # Young's modulus of both blocks [MPa]
    transfer: Literal["area", "point"] = "area"  # the master's load: tributary area or point
    density: float = 1e-9  # both blocks [t/mm^3] (explicit solver only)


def scene(p: Params) -> Scene:
    """The two blocks, their rollers, the pressure and the interface."""
    require(p, positive=("pressure", "lower_cells", "upper_cells", "modulus", "density"))
    mesh = blocks([
        Block("lower", (SIDE, SIDE, HEIGHT), (p.lower_cells, p.lower_cells, 2)),
        Block("upper", (SIDE, SIDE, HEIGHT), (p.upper_cells, p.upper_cells, 2),
              origin=(0.0, 0.0, HEIGHT)),
    ])
    solid = ElasticSolid(IsotropicElasticity(E=p.modulus, nu=0.3), density=p.density)
    rollers = tuple(Displacement(b, f"{b}_{face}", reaction=False, **{axis: 0.0})
                    for b in ("lower", "upper") for face, axis in (("xmin", "x"),
                                                                   ("ymin", "y")))
    return Scene(
        "contact_patch", mesh, (Body("lower", solid, region="lower"),
                                Body("upper", solid, region="upper")),
        displacements=(Displacement("lower", "lower_bottom", z=0.0), *rollers),
        tractions=(Traction("upper", "upper_top", z=Linear(-p.pressure)),),
        sliding=(Sliding("upper", "lower", "lower_top", "upper", "upper_bottom",
                         transfer=p.transfer),))


def build(p: Params) -> Job:
    patch = scene(p)

    def metrics(rec, model) -> dict:
        lo, hi = model.sliding[0].pressure_range()
        return {"pressure_min_MPa": lo, "pressure_max_MPa": hi,
                "pressure_deviation_max": max(abs(lo / p.pressure - 1.0),
                                              abs(hi / p.pressure - 1.0)),
                "normal_force_N": float(rec.column("sliding_upper_normal_N")[-1]),
                "support_force_N": float(rec.column("reaction_lower_lower_bottom_z_N")[-1])}

    return Job(scene=patch, steps=StepControl(initial=0.5, max=0.5),
               newton=NewtonOptions(line_search="basic"), metrics=metrics)


if __name__ == "__main__":
    main(build, Params, "contact_patch")
