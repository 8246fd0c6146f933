"""C365 through-thickness compression of a honeycomb patch whose cell walls are modelled.

The meso-scale virtual test of the paper's core ("Core crushing", Fig. 6): a patch of
``cells`` hexagonal cells (ribbon walls doubled) between two platens bonded to the wall
edges, the top platen moved down. The walls are thin solids (quadratic hexahedra, one
through the thickness; ``tests/test_meso.py`` checks their bending and buckling against
plate theory) of the paper's cardboard (Table 1: E 0.41 GPa, nu 0.21). The cell
dimensions are estimates (docs/materials.md): the paper shows them only in its Fig. 3.
A seeded smooth imperfection (``imperfection`` mm) lets the walls choose a buckling path.

What it gives: the nominal stress-strain curve, its initial modulus against Gibson and
Ashby's E_s x relative density, the buckling peak against the linear buckling strain of
the patch itself (``--set buckling=true``) and against plate buckling of the walls, and
a picture of the buckled walls.

The bottom platen is bonded; the top one is bonded too (default) or, with
``platen=contact``, a rigid tool that touches the wall edges with friction (the paper's
original meso model; contact is enforced at the wall edges' element vertices).

Limits of this first meso model (issue 20, in progress): the walls are elastic (no
fracture at the 0.067 strain of Table 1: ``max_wall_strain`` says where it would be
passed), walls do not touch each other (no self-contact: the run is only meaningful
before folds meet, well short of densification), and the paper's dummy flanges and infill
are not built yet.

Accuracy of the defaults: not yet studied (the wall tests give 1% in bending and 2.3%
in buckling at their mesh sizes).

Run: ``python cases/meso_compression.py`` or ``mpirun -n 2 python cases/meso_compression.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from forming.case import main, require
from forming.contact.shapes import Plane
from forming.job import Job, Response
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.library import honeycomb_core
from forming.materials.solids import ElasticSolid
from forming.meso.honeycomb import HoneycombCell, HoneycombPatch, honeycomb_mesh
from forming.meso.post import folded_walls_picture, wall_strain_extremes
from forming.output import plot_curves
from forming.scene import Body, Contact, Displacement, Linear, Scene, Stabilisation, Tool
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl


@dataclass(frozen=True)
class Params:
    """Parameters of the meso-scale compression case (mm, MPa)."""

    cells: tuple[int, ...] = (3, 3)  # cells along x (ribbon) and y
    wall_length: float = 5.0  # inclined wall length l [mm] (estimate, Fig. 3)
    wall_thickness: float = 0.30  # single wall thickness t [mm] (estimate, t/l = 0.06)
    angle_deg: float = 30.0  # inclined walls' angle to y [deg] (regular hexagon: 30)
    double_walls: bool = True  # ribbon walls are two bonded sheets (expanded core)
    height: float = 20.0  # core thickness [mm] (the paper's core)
    size: float = 1.2  # in-plane element size [mm] (before the quad split in four)
    layers: int = 8  # elements along the cell axis
    wall_modulus: float = 410.0  # wall Young's modulus [MPa] (Table 1)
    wall_poisson: float = 0.21  # wall Poisson ratio (Table 1)
    strain: float = 0.06  # nominal strain reached (0 < strain < 1)
    imperfection: float = 0.05  # largest imperfection move [mm]
    seed: int = 0  # seed of the imperfection
    buckling: bool = False  # also compute the linear buckling strains (platens bonded)
    stabilisation: float = 2e-4  # viscous stabilisation, dissipated energy fraction (0: none)
    platen: Literal["bonded", "contact"] = "bonded"  # top platen held to the walls or touching
    platen_friction: float = 0.36  # platen-wall friction when touching (tool-core, stated)
    max_step: float = 0.05  # largest load step (fraction of the stroke)


def patch_of(p: Params) -> HoneycombPatch:
    """The honeycomb patch the parameters describe."""
    cell = HoneycombCell(p.wall_length, None, p.wall_thickness, p.angle_deg, p.double_walls)
    return HoneycombPatch(cell, tuple(p.cells), p.height, p.size / 2, p.layers,
                          p.imperfection, p.seed)


def build(p: Params) -> Job:
    require(p, positive=("wall_length", "wall_thickness", "height", "size", "wall_modulus"),
            nonnegative=("imperfection", "stabilisation", "platen_friction"),
            fraction=("strain",))
    patch = patch_of(p)
    mesh = honeycomb_mesh(patch)
    material = ElasticSolid(IsotropicElasticity(p.wall_modulus, p.wall_poisson))
    stroke = p.strain * p.height
    bottom = Displacement("walls", "bottom", x=0.0, y=0.0, z=0.0, reaction=False)
    bonded = (bottom, Displacement("walls", "top", x=0.0, y=0.0, z=Linear(-stroke)))
    body = Body("walls", material, degree=2)
    # the linear buckling analysis holds both platens (contact is not linear in the load)
    buckling_strains = (_linear_buckling(Scene("meso_buckling", mesh, (body,), bonded),
                                         p.strain) if p.buckling else None)
    if p.platen == "bonded":
        loading = dict(displacements=bonded)
        force_column, scale = "reaction_top_z_N", -1.0
    else:  # a rigid platen that touches the wall edges and may slide on them
        platen = Plane((0.0, 0.0, p.height), (0.0, 0.0, -1.0))
        loading = dict(displacements=(bottom,),
                       tools=(Tool("platen", platen, z=Linear(-stroke)),),
                       contacts=(Contact("walls", "top", "platen", friction=p.platen_friction),))
        force_column, scale = "force_platen_z_N", 1.0
    scene = Scene(
        name="meso_compression",
        mesh=mesh,
        bodies=(body,),
        stabilisation=Stabilisation(p.stabilisation) if p.stabilisation > 0 else None,
        **loading,
    )
    rho = patch.relative_density()
    t_l = p.wall_thickness / p.wall_length
    # plate buckling of a single wall (width l, simply supported, k = 4): the strain at
    # which the inclined walls buckle; the double walls need four times as much
    plate_strain = 4 * math.pi**2 / (12 * (1 - p.wall_poisson**2)) * t_l**2

    def nominal(rec) -> tuple[np.ndarray, np.ndarray]:
        e = rec.column("t") * p.strain
        s = scale * rec.column(force_column) / patch.footprint
        return e, s

    def metrics(rec, model) -> dict:
        e, s = nominal(rec)
        peak = int(np.argmax(s))
        beyond = e >= max(2 * e[peak], 0.05)
        strain_max, strain_min = wall_strain_extremes(model.body)
        out = {
            "relative_density": rho,
            "modulus_MPa": float(s[1] / e[1]) if len(e) > 1 else float("nan"),
            "gibson_ashby_modulus_MPa": p.wall_modulus * rho,
            "peak_stress_MPa": float(s[peak]),
            "peak_strain": float(e[peak]),
            "plate_buckling_strain": plate_strain,
            "plateau_stress_MPa": float(s[beyond].mean()) if beyond.any() else float("nan"),
            "final_strain": float(e[-1]),
            "final_stress_MPa": float(s[-1]),
            "max_wall_strain": strain_max,
            "min_wall_strain": strain_min,
        }
        if buckling_strains is not None:
            out["buckling_strain"] = float(buckling_strains[0])
        return out

    def plots(rec, out: Path) -> list[Path]:
        e, s = nominal(rec)
        grid = np.linspace(0.0, p.strain, 100)
        macro = honeycomb_core("isotropic").curve
        curves = [(e, s, "computed (meso, elastic walls)", "o-"),
                  (e, p.wall_modulus * rho * e, "E_s x relative density", "k--"),
                  (grid, macro.interpolate(grid), "macro model's C365 curve (estimate)", "k:")]
        return [plot_curves(out / "stress_strain.png", curves, "nominal strain",
                            "nominal stress [MPa]",
                            f"Meso compression, {p.cells[0]} x {p.cells[1]} cells")]

    def pictures(model, out: Path) -> list[Path]:
        return folded_walls_picture(model, out, f"Buckled walls at {p.strain:g} nominal strain")

    return Job(
        scene=scene,
        steps=StepControl(initial=0.02, max=p.max_step, min=1e-5),
        newton=NewtonOptions(),
        metrics=metrics, plots=plots, pictures=pictures,
        response=Response(force_column, stroke, scale, "platen force"),
    )


def _linear_buckling(scene: Scene, strain: float) -> np.ndarray:
    """Nominal strains at which the perfect patch buckles (linear buckling analysis)."""
    from forming.model import Model
    from forming.solver.buckling import buckling_modes
    from forming.solver.implicit import ImplicitSolver

    model = Model(scene)
    modes = buckling_modes(model, ImplicitSolver(model), n_modes=3)
    return modes.factors * strain


if __name__ == "__main__":
    main(build, Params, "meso_compression")
