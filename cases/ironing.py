"""Ironing: a stiff curved die pressed into a soft block, then slid along it with friction.

The finite-sliding benchmark of Puso & Laursen (2004) and Yang, Laursen & Meng (2005),
in mm and in plane strain (one element across y, y held on both faces): a die with a
circular bottom (radius ``die_radius``) is pressed ``depth`` mm into a soft elastic block
and then dragged ``slide`` mm along it, many block elements, with Coulomb friction
``friction``. The die's curved face is the slave side, meshed finer than the block's top
face (the master): the meshes do not match and the die's nodes cross the block's facet
edges all along the slide (node to surface, docs/theory.md, section 11).

What it checks: while sliding, the force the block puts on the die is smooth (a node to
surface contact with facet normals jumps each time a node crosses a facet edge) and
tangential over normal equals the friction coefficient. ``metrics``:
``friction_ratio_mean`` over the steady slide (from ``steady`` of the slide on),
``normal_oscillation`` and ``tangential_oscillation`` (largest deviation from a straight
line fitted to the force over the steady slide, relative to its mean).

Accuracy of the defaults (docs/validation.md, "Convergence of the shipped cases"): the
friction ratio stays within 0.1% of the 1.25 mm block element's (5.6 times the wall
time); the force oscillation (0.26% of the mean) is 62% above that finer mesh's.

Run: ``python cases/ironing.py`` or ``mpirun -n 2 python cases/ironing.py``.
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
from forming.mesh import Block, blocks
from forming.scene import Body, Displacement, Scene, Sliding, Table
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

PRESS = 0.2  # part of the load parameter spent pressing the die in


@dataclass(frozen=True)
class Params:
    """Parameters of the ironing test (mm, MPa)."""

    depth: float = 2.0  # die pressed this far into the block [mm]
    slide: float = 40.0  # then dragged this far along x [mm]
    friction: float = 0.3  # die-block Coulomb coefficient (the benchmark's)
    die_radius: float = 60.0  # radius of the die's curved face [mm]
    block_element: float = 2.5  # block element size [mm]
    die_cells: int = 24  # die elements across its 40 mm width
    block_modulus: float = 10.0  # soft block's Young's modulus [MPa]
    stiffness_ratio: float = 1000.0  # die modulus over the block's
    steady: float = 0.25  # the steady slide starts after this part of the slide
    max_step: float = 0.01  # largest load step
    transfer: Literal["area", "point"] = "area"  # the master's load: tributary area or point


WIDTH, DEPTH_Y, HEIGHT = 120.0, 10.0, 30.0  # the block [mm]
DIE_WIDTH, DIE_HEIGHT, DIE_X = 40.0, 10.0, 15.0  # the die, and its start (left edge) [mm]


def die_shape(radius: float):
    """The die's warp: its flat bottom bent into a circular arc, its top left flat."""
    centre = DIE_X + 0.5 * DIE_WIDTH

    def warp(x: np.ndarray) -> np.ndarray:
        sag = radius - np.sqrt(radius**2 - (x[:, 0] - centre) ** 2)
        bottom = HEIGHT
        x[:, 2] += sag * (1.0 - (x[:, 2] - bottom) / DIE_HEIGHT)
        return x

    return warp


def scene(p: Params) -> Scene:
    """The block, the die touching it at its lowest point, and the sliding contact."""
    require(p, positive=("depth", "slide", "block_element", "die_cells", "block_modulus",
                         "stiffness_ratio", "max_step"),
            nonnegative=("friction",), fraction=("steady",))
    if not p.die_radius > 0.5 * DIE_WIDTH:
        raise InputError("--set die_radius", f"must exceed half the die's width "
                         f"({0.5 * DIE_WIDTH} mm), got {p.die_radius}")
    nx, nz = round(WIDTH / p.block_element), round(HEIGHT / p.block_element)
    mesh = blocks([
        Block("block", (WIDTH, DEPTH_Y, HEIGHT), (nx, 1, nz)),
        Block("die", (DIE_WIDTH, DEPTH_Y, DIE_HEIGHT), (p.die_cells, 1, 4),
              origin=(DIE_X, 0.0, HEIGHT), warp=die_shape(p.die_radius)),
    ])
    soft = IsotropicElasticity(E=p.block_modulus, nu=0.3)
    stiff = IsotropicElasticity(E=p.block_modulus * p.stiffness_ratio, nu=0.3)
    press = Table((0.0, PRESS, 1.0), (0.0, -p.depth, -p.depth))
    drag = Table((0.0, PRESS, 1.0), (0.0, 0.0, p.slide))
    plane = tuple(Displacement(b, f"{b}_{side}", y=0.0, reaction=False)
                  for b in ("block", "die") for side in ("ymin", "ymax"))
    return Scene(
        "ironing", mesh, (Body("block", ElasticSolid(soft), region="block"),
                          Body("die", ElasticSolid(stiff), region="die")),
        displacements=(Displacement("block", "block_bottom", x=0.0, y=0.0, z=0.0,
                                    reaction=False),
                       Displacement("die", "die_top", x=drag, z=press), *plane),
        sliding=(Sliding("die", "block", "block_top", "die", "die_bottom",
                         friction=p.friction, transfer=p.transfer),))


def oscillation(s: np.ndarray, f: np.ndarray) -> float:
    """Largest deviation of ``f`` from its straight-line fit over ``s``, over its mean."""
    fit = np.polyval(np.polyfit(s, f, 1), s)
    return float(np.abs(f - fit).max() / abs(f.mean()))


def build(p: Params) -> Job:
    iron = scene(p)

    def slide_of(t: np.ndarray) -> np.ndarray:
        return np.clip((t - PRESS) / (1.0 - PRESS), 0.0, None) * p.slide

    def metrics(rec, model) -> dict:
        s = slide_of(rec.column("t"))
        steady = s > p.steady * p.slide
        fx = -rec.column("sliding_die_x_N")[steady]
        fz = rec.column("sliding_die_z_N")[steady]
        ratio = fx / fz
        return {"friction_ratio_mean": float(ratio.mean()),
                "friction_ratio_min": float(ratio.min()),
                "friction_ratio_max": float(ratio.max()),
                "normal_force_mean_N": float(fz.mean()),
                "normal_oscillation": oscillation(s[steady], fz),
                "tangential_oscillation": oscillation(s[steady], fx),
                "steady_points": int(steady.sum()),
                "penetration_max_mm": float(rec.column("sliding_die_penetration_mm").max())}

    def plots(rec, out: Path) -> list[Path]:
        from forming.output import plot_curves

        s = slide_of(rec.column("t"))
        on = rec.column("t") > PRESS
        fx, fz = -rec.column("sliding_die_x_N")[on], rec.column("sliding_die_z_N")[on]
        return [plot_curves(Path(out) / "ironing_forces.png",
                            [(s[on], fz, "normal force", "o-"),
                             (s[on], fx, "tangential force", "s-"),
                             (s[on], p.friction * fz, f"{p.friction} x normal", "--")],
                            "slide [mm]", "force of the block on the die [N]",
                            "Ironing: a stiff die slid over a soft block (non-matching meshes)")]

    return Job(scene=iron, steps=StepControl(initial=min(0.02, p.max_step), max=p.max_step),
               newton=NewtonOptions(line_search="basic"), metrics=metrics, plots=plots)


if __name__ == "__main__":
    main(build, Params, "ironing")
