"""Three-point bending of a core strip over the hemisphere's die, against beam theory.

A strip of the elastic core (the shipped moduli, no foam), 300 mm long, 20 mm wide and
20 mm thick, lies across the die's 144 mm opening (edge radius 2 mm: supports
``L = 148`` mm apart); the hemispherical punch (100 mm) pushes its middle down by 1 mm,
friction 0.36 on both tools. The overhangs carry no load: they lift about the die edge,
their nodes at zero pressure, as the hemisphere's flange does. Quarter model; the force
is the whole strip's.

Beam theory (Timoshenko, simply supported; the in-plane modulus E and the transverse
shear modulus G act in the strip's plane) gives

    P = delta / (L^3 / (48 E I) * (1 - 1.5 mu t / L) + L / (4 kappa G A)),

``I = b t^3 / 12``, ``A = b t``, ``kappa = 5/6``. The factor ``1 - 1.5 mu t / L`` is the
friction on the sliding supports: it acts on the bottom face, half the thickness below
the neutral axis, and its end moments ``mu (P / 2) t / 2`` cut the midspan deflection.
Beam theory leaves out the indentation under the punch and over the supports.

The transverse core bends with E = 0.2 MPa against G = 1.56 MPa: 8-node hexahedra with
full integration add a parasitic shear of order ``(G / E) (a / t)^2`` of the bending
energy (element length a along the strip), so coarse meshes overstiffen it
(docs/validation.md).

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): the
force is 3.7% above its Richardson value (1.026 of beam theory, order 5); the next finer
mesh (120 x 1 x 16) changes it by 3.4% for 20 times the wall time.

Explicitly (``--set solver=explicit``) the strip is pressed over 0.4 s: its kinetic energy,
mostly the overhangs lifting about the die edges, stays within 3.9% of the internal
energy, and the force is 1.019 of beam theory (docs/validation.md).

Run: ``python cases/strip_bending.py --set elasticity=transverse``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

from forming import post
from forming.blanks import rectangular_blank
from forming.case import main, require
from forming.job import Job, Response
from forming.materials.library import core_data, honeycomb_core
from forming.scene import Scene
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl
from forming.tooling import hemisphere_tools

KAPPA = 5.0 / 6.0  # shear correction factor of a rectangular section


@dataclass(frozen=True)
class Params:
    """Parameters of the strip-bending case (mm)."""

    length: float = 300.0  # strip length [mm]
    width: float = 20.0  # strip width [mm]
    thickness: float = 20.0  # core thickness [mm]
    die_diameter: float = 144.0  # die opening [mm]
    edge_radius: float = 2.0  # die edge radius [mm]
    punch_diameter: float = 100.0  # punch diameter [mm]
    stroke: float = 1.0  # punch travel [mm]
    friction: float = 0.36  # tool-core Coulomb coefficient
    cells: tuple[int, ...] = (60, 1, 8)  # elements along x, y and through the core (quarter)
    degree: int = 1  # polynomial degree of the displacement (1 or 2)
    elasticity: Literal["transverse", "isotropic"] = "transverse"  # core elasticity
    tool_stick: Literal["augmented", "elastic_slip"] = "elastic_slip"  # tool stick law
    line_search: Literal["basic", "bt"] = "basic"  # Newton line search
    max_step: float = 0.25  # largest load step (fraction of the stroke)


def beam_force(p: Params) -> float:
    """Punch force of Timoshenko beam theory with support friction [N] (module docstring)."""
    data = core_data()[p.elasticity]
    if p.elasticity == "transverse":
        e, g = data["E_inplane"]["value"], data["G_through"]["value"]
    else:
        e = data["E"]["value"]
        g = e / (2.0 * (1.0 + data["nu"]["value"]))
    span = p.die_diameter + 2.0 * p.edge_radius
    inertia = p.width * p.thickness**3 / 12.0
    bending = span**3 / (48.0 * e * inertia) * (1.0 - 1.5 * p.friction * p.thickness / span)
    shear = span / (4.0 * KAPPA * g * p.width * p.thickness)
    return p.stroke / (bending + shear)


def build(p: Params) -> Job:
    require(p, positive=("length", "width", "thickness", "die_diameter", "edge_radius",
                         "punch_diameter", "stroke", "max_step"),
            nonnegative=("friction",))
    half = p.length / 2
    blank = rectangular_blank(half, p.width / 2, p.thickness, p.cells,
                              honeycomb_core(p.elasticity, plastic=False))
    bodies = tuple(dataclasses.replace(b, degree=p.degree) for b in blank.bodies)
    tools, contacts = hemisphere_tools(blank, p.punch_diameter, p.die_diameter, p.edge_radius,
                                       p.stroke, p.friction, False, p.tool_stick)
    scene = Scene(name="strip_bending", mesh=blank.mesh, bodies=bodies,
                  displacements=blank.symmetry(), tools=tools, contacts=contacts,
                  symmetry_copies=4)
    estimate = beam_force(p)

    def metrics(rec, model) -> dict:
        force = float(rec.column("force_punch_z_N")[-1])
        return {"punch_force_N": force, "beam_theory_force_N": estimate,
                "force_over_beam_theory": force / estimate,
                "die_force_z_N": float(rec.column("force_die_z_N")[-1]),
                "die_force_x_N": float(rec.column("force_die_x_N")[-1])} | (
            post.contact_metrics(rec, model))

    return Job(scene=scene, steps=StepControl(initial=p.max_step, max=p.max_step,
                                              min=min(1e-4, p.max_step)),
               newton=NewtonOptions(line_search=p.line_search), metrics=metrics,
               response=Response("force_punch_z_N", p.stroke, label="punch force"),
               # the overhangs' lift is the slowest motion (docs/theory.md section 12)
               explicit=ExplicitOptions(loading_time=0.4))


if __name__ == "__main__":
    main(build, Params, "strip_bending")
