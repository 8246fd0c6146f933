"""Sled test of the skin-core interface: a fabric skin dragged over a core block.

The paper measures fabric-core friction with a sled: a fabric under a normal pressure of
2 kPa is pulled over the core and the pulling force over the normal force gives the
coefficient, 0.52. Here a sandwich blank (core between two one-ply skins) rests on its
bottom skin, which is held; the bottom interface is bonded. The top skin carries the 2 kPa
pressure on its top face and is dragged along x by its top face (the sled's plate), so
the top interface slips. ``metrics.friction_ratio`` is the drag force over the normal
force carried by the interface once the skin slides; it should equal the coefficient
(``friction``).

Explicitly (``--set solver=explicit``) the pull takes 0.4 s and the core, held by the
bonded bottom skin, is damped in proportion to its mass (1e4 1/s, ``explicit.damping``
on ``explicit.damped_bodies=core``): undamped, the core's shear mode rings as the skin
sticks and slips over it, the friction force changes sign with it and the drag fell to
0.16 of the normal force at 0.05 s (0.08 at 0.2 s). Damped, the ratio is 0.5199 against
0.5200 implicitly, the damping's work 0.004% of the external work (docs/validation.md).

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): the
friction ratio is the same to 1e-4 on 20, 10 and 5 mm elements.

Run: ``python cases/skin_sled.py`` or ``mpirun -n 2 python cases/skin_sled.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forming.case import main, require
from forming.errors import InputError
from forming.job import Job
from forming.materials.fabric import NonCrimpFabric
from forming.materials.library import honeycomb_core
from forming.sandwich import Outline, sandwich_blank
from forming.scene import Body, Displacement, Interface, Scene, Table, Traction
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl

FABRIC_CORE_FRICTION = 0.52  # paper, section "Friction between materials"
CORE_DAMPING = 1e4  # mass-proportional damping of the held core in explicit runs [1/s]
LOADING = 0.2  # share of the load programme that puts the weight on, before the pull


@dataclass(frozen=True)
class Params:
    """Parameters of the sled test (mm, MPa)."""

    length: float = 50.0  # sled length [mm] (paper: 50 x 100 sample)
    width: float = 50.0  # sled width [mm]
    core_thickness: float = 10.0  # core thickness [mm]
    skin_thickness: float = 0.4  # ply thickness [mm]
    element: float = 10.0  # element size [mm]
    pressure: float = 0.002  # normal pressure [MPa] (paper: 2 kPa)
    friction: float = FABRIC_CORE_FRICTION  # skin-core Coulomb coefficient (paper: 0.52)
    drag: float = 2.0  # pull [mm]
    steps: int = 10  # load steps


def build(p: Params) -> Job:
    require(p, positive=("pressure", "drag", "length", "width"), nonnegative=("friction",))
    if p.steps < 2:
        raise InputError("--set steps", f"must be >= 2, got {p.steps}")
    mesh = sandwich_blank(Outline.rectangle(p.length, p.width), core_thickness=p.core_thickness,
                          skin_thickness=p.skin_thickness, plies=1, element_size=p.element,
                          core_layers=2)
    fabric = NonCrimpFabric(thickness=p.skin_thickness)
    scene = Scene(
        name="skin_sled", mesh=mesh,
        bodies=(Body("core", honeycomb_core(plastic=False), region="core"),
                Body("skin_bottom", fabric, region="skin_bottom"),
                Body("skin_top", fabric, region="skin_top")),
        displacements=(
            Displacement("skin_bottom", "bottom", x=0.0, y=0.0, z=0.0, reaction=False),
            # the sled's plate drags the top face along x and keeps it from drifting in y,
            # once the weight is on (a weight put on at once rings in an explicit run)
            Displacement("skin_top", "top", x=Table((0.0, LOADING, 1.0), (0.0, 0.0, p.drag)),
                         y=0.0),
        ),
        tractions=(Traction("skin_top", "top", z=Table((0.0, LOADING, 1.0),
                                                       (0.0, -p.pressure, -p.pressure))),),
        interfaces=(Interface("interface_bottom", "core", "skin_bottom", kind="bonded"),
                    Interface("interface_top", "core", "skin_top", friction=p.friction)),
    )
    area = p.length * p.width

    def metrics(rec, model) -> dict:
        drag = np.abs(rec.column("reaction_skin_top_top_x_N"))
        normal = rec.column("normal_force_interface_top_N")
        ratio = drag[-1] / normal[-1]
        return {
            "friction_ratio": float(ratio),
            "friction_ratio_error_rel": float(abs(ratio - p.friction) / p.friction),
            "friction_ratio_applied_load": float(drag[-1] / (p.pressure * area)),
            "normal_force_N": float(normal[-1]),
            "drag_force_N": float(drag[-1]),
            "slip_mm": float(rec.column("slip_interface_top_mm")[-1]),
            "bonded_slip_mm": float(rec.column("slip_interface_bottom_mm")[-1]),
            "penetration_mm": float(rec.column("penetration_interface_top_mm").max()),
        }

    def plots(rec, out: Path) -> list[Path]:
        from forming.output import plot_curves

        d = rec.column("t") * p.drag
        ratio = np.abs(rec.column("reaction_skin_top_top_x_N")) / np.maximum(
            rec.column("normal_force_interface_top_N"), 1e-30)
        return [plot_curves(Path(out) / "skin_sled.png",
                            [(d, ratio, "computed", "o-"),
                             (d, np.full_like(d, p.friction), f"mu = {p.friction}", "--")],
                            "pull [mm]", "drag / normal force",
                            "Sled: fabric skin dragged over the core under 2 kPa")]

    return Job(scene=scene, steps=StepControl(initial=1.0 / p.steps, max=1.0 / p.steps),
               newton=NewtonOptions(line_search="bt"), metrics=metrics, plots=plots,
               explicit=ExplicitOptions(loading_time=0.4, damping=CORE_DAMPING,
                                        damped_bodies=("core",)))


if __name__ == "__main__":
    main(build, Params, "skin_sled")
