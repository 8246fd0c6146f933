"""Large-slip sled: a fabric dragged across a core over many elements (finite sliding).

The paper's sled (2 kPa on a fabric pulled over the core, friction 0.52) taken far beyond
what the node-to-node interface of ``skin_sled`` can follow: the fabric and the core are
meshed apart (non-matching meshes: 5 mm fabric elements on 12.5 mm core elements by
default) and the fabric is pulled ``drag`` mm, 5.6 core element lengths by default, with
node-to-surface finite sliding (docs/theory.md, section 11). The fabric starts so that
none of its nodes lies on a core facet's edge. ``metrics.friction_ratio_*`` is the force
the core puts on the fabric along x over the normal force, once sliding (after 5% of
the pull); it should equal the coefficient at every step. The weight goes on over the
first tenth of the load programme (``weight_first``), the pull follows.

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): the
friction ratio is 0.51999 with 10 and 20 fabric elements per side (the finer costs 4.3
times the wall time); 5 per side, coarser than the core, stops in its first step.

Run: ``python cases/sliding_sled.py`` or ``mpirun -n 2 python cases/sliding_sled.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from forming.case import main, require
from forming.errors import InputError
from forming.job import Job
from forming.materials import ElasticSolid, IsotropicElasticity
from forming.materials.fabric import NonCrimpFabric
from forming.materials.library import honeycomb_core
from forming.mesh import Block, blocks
from forming.scene import Body, Displacement, Linear, Scene, Sliding, Table, Traction
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

FABRIC_CORE_FRICTION = 0.52  # paper, section "Friction between materials"


@dataclass(frozen=True)
class Params:
    """Parameters of the large-slip sled (mm, MPa)."""

    drag: float = 70.0  # pull [mm] (5.6 core elements)
    pressure: float = 0.002  # normal pressure [MPa] (paper: 2 kPa)
    friction: float = FABRIC_CORE_FRICTION  # skin-core Coulomb coefficient (paper: 0.52)
    core_element: float = 12.5  # core element size in plan [mm]
    skin_cells: int = 10  # fabric elements along each side (50 x 48 mm)
    overlap: float = 0.0  # fabric placed this far into the core at the start [mm]
    skin: Literal["fabric", "elastic"] = "fabric"  # NCF, or an elastic layer (E 100 MPa)
    max_step: float = 0.05  # largest load step
    transfer: Literal["area", "point"] = "area"  # the master's load: tributary area or point
    stabilisation: float = 0.0  # weak spring on the fabric's motion within a step (x penalty)
    weight_first: float = 0.1  # load share that puts the weight on before the pull (0: at once)
    elastic_slip: float = 0.005  # stick slip at the friction limit, of the facet edge (implicit)


def scene(p: Params) -> Scene:
    """The core block, the fabric on it and the sliding contact between them."""
    require(p, positive=("pressure", "core_element", "skin_cells", "max_step", "elastic_slip"),
            nonnegative=("drag", "friction", "overlap", "stabilisation"))
    if not 0.0 <= p.weight_first < 1.0:
        raise InputError("--set weight_first", f"must lie in [0, 1), got {p.weight_first}")
    share = p.weight_first
    pull = Table((0.0, share, 1.0), (0.0, 0.0, p.drag)) if share > 0 else Linear(p.drag)
    weight = (Table((0.0, share, 1.0), (0.0, -p.pressure, -p.pressure)) if share > 0
              else -p.pressure)
    mesh = blocks([
        Block("core", (200.0, 50.0, 10.0), (round(200.0 / p.core_element),
                                            round(50.0 / p.core_element), 2)),
        Block("skin", (50.0, 48.0, 0.4), (p.skin_cells, p.skin_cells, 1),
              origin=(21.3, 0.7, 10.0 - p.overlap)),
    ])
    skin = NonCrimpFabric(thickness=0.4) if p.skin == "fabric" else ElasticSolid(
        IsotropicElasticity(E=100.0, nu=0.3))
    return Scene(
        "sliding_sled", mesh, (Body("core", honeycomb_core(plastic=False), region="core"),
                               Body("skin", skin, region="skin")),
        displacements=(Displacement("core", "core_bottom", x=0.0, y=0.0, z=0.0,
                                    reaction=False),
                       # the sled's plate pulls the top face and keeps it from drifting in
                       # y, once the weight is on (put on at once, it rings explicitly)
                       Displacement("skin", "skin_top", x=pull, y=0.0)),
        tractions=(Traction("skin", "skin_top", z=weight),),
        sliding=(Sliding("skin", "core", "core_top", "skin", "skin_bottom",
                         friction=p.friction, transfer=p.transfer,
                         stabilisation=p.stabilisation, elastic_slip=p.elastic_slip),))


def build(p: Params) -> Job:
    sled = scene(p)

    def metrics(rec, model) -> dict:
        t = rec.column("t")
        sliding = t > p.weight_first + 0.05 * (1.0 - p.weight_first)  # after 5% of the pull
        normal = rec.column("sliding_skin_z_N")
        ratio = -rec.column("sliding_skin_x_N")[sliding] / normal[sliding]
        return {"friction_ratio_min": float(ratio.min()),
                "friction_ratio_max": float(ratio.max()),
                "normal_force_N": float(normal[-1]),
                "drag_force_N": float(abs(rec.column("reaction_skin_skin_top_x_N")[-1])),
                "penetration_max_mm": float(rec.column("sliding_skin_penetration_mm").max())}

    def plots(rec, out: Path) -> list[Path]:
        from forming.output import plot_curves

        d = rec.column("t") * p.drag
        ratio = -rec.column("sliding_skin_x_N") / np.maximum(rec.column("sliding_skin_z_N"),
                                                             1e-30)
        return [plot_curves(Path(out) / "sliding_sled.png",
                            [(d, ratio, "computed", "o-"),
                             (d, np.full_like(d, p.friction), f"mu = {p.friction}", "--")],
                            "pull [mm]", "friction force / normal force",
                            "Large-slip sled: fabric over a core, non-matching meshes")]

    return Job(scene=sled, steps=StepControl(initial=min(0.02, p.max_step), max=p.max_step),
               newton=NewtonOptions(line_search="basic"), metrics=metrics, plots=plots)


if __name__ == "__main__":
    main(build, Params, "sliding_sled")
