"""C365 through-thickness compression of a honeycomb patch whose cell walls are modelled.

The meso-scale virtual test of the paper's core ("Core crushing", Fig. 6): a patch of
``cells`` hexagonal cells (ribbon walls doubled) between two platens bonded to the wall
edges, the top platen moved down. The walls are thin solids (quadratic hexahedra, one
through the thickness; ``tests/test_meso.py`` checks their bending and buckling against
plate theory) of the paper's cardboard (Table 1: E 0.41 GPa, nu 0.21). The cell
dimensions are estimates (docs/materials.md): the paper shows them only in its Fig. 3.
A seeded smooth imperfection (``imperfection`` mm) lets the walls choose a buckling path.

What it gives: the nominal stress-strain curve (also as ``c365_curve.csv``, the macro
core's format; ``forming calibrate meso_compression`` makes it the macro curve), its
initial modulus against Gibson and Ashby's E_s x relative density, the buckling peak
against the linear buckling strain of the patch itself (``--set buckling=true``) and
against plate buckling of the walls, and a picture of the buckled walls.

``load=shear_x`` or ``load=shear_y`` moves the bonded top platen sideways instead (the
platens keep their distance: a C273 shear test; nominal shear strain = move / height):
``shear_modulus_MPa``, the transverse shear modulus the macro core needs.
``load=tension_x`` or ``load=tension_y`` pulls the walls in their plane instead, by the
patch's cut faces, with no platens (at least 3 cells along y, 2 along x): the lattice's
``inplane_modulus_MPa`` and ``inplane_poisson`` (measured where the patch has the
lattice's own condition: ``forming/meso/inplane.py``) against Gibson and Ashby's values,
and the patch's own ``patch_modulus_MPa``; the in-plane modulus the macro core needs.

The bottom platen is bonded; the top one is bonded too (default) or, with
``platen=contact``, a rigid tool that touches the wall edges with friction (the paper's
original meso model; contact is enforced at the wall edges' element vertices). The
paper's two remedies for its tool-wall penetration (Table 3): ``variant=infill`` fills
the pores with a soft dummy infill (E 0.3 MPa, nu 0; linear hexahedra);
``variant=flange`` puts a soft dummy flange (E 4 MPa, nu 0.21; ``flange_width`` into
the pores, ``flange_thickness`` thick, our estimates of a geometry the paper does not
give) along every wall's top edge. Either is a second body bonded to the walls, which
the top platen holds or touches as it does the walls.

The walls fracture (``fracture=true``, the default): damage on the largest principal
strain past Table 1's 0.067, its tensile part only, regularised by the crack band with
an estimated fracture energy ``fracture_energy`` (docs/materials.md); a point whose band
is spent is eroded (``erosion``), as the paper's explicit code deletes failed elements
(an implicit run then needs the stabilisation, which holds the eroded elements' nodes).
``fracture=false`` keeps the walls elastic (``max_wall_strain`` then says where they
would have torn).

Walls that fold onto each other touch (``self_contact``, the default; docs/theory.md
§15): the explicit solver enforces the contact by penalty; an implicit run stops at the
first step in which a wall node is behind another wall's face, and says so.

Limits of this meso model (issue 20, in progress): on the default meshes the implicit
run stops some way past the peak (docs/validation.md, "fracturing cell walls", says
where). The dummies stay elastic unless ``dummy_deletion=true``, which deletes (erodes)
their points at Table 3's fracture strains (infill 0.010, flanges 0.067), in compression
as in tension; an implicit run has nothing to hold a deleted dummy's nodes but the
stabilisation.

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

from forming.calibrate import CURVE_FILE
from forming.case import main, require
from forming.contact.shapes import Plane
from forming.errors import InputError
from forming.job import Job, Response
from forming.materials.curves import CompressionCurve
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.fracture import FracturingSolid
from forming.materials.library import honeycomb_core
from forming.materials.solids import ElasticSolid
from forming.meso import WALL_NEWTON
from forming.meso.honeycomb import (
    WALL_DENSITY,
    HoneycombCell,
    HoneycombPatch,
    honeycomb_mesh,
    patch_box,
)
from forming.meso.inplane import AXES, gibson_ashby_inplane, inplane_loading, lattice_strains
from forming.meso.post import folded_walls_picture, wall_strain_extremes
from forming.output import plot_curves
from forming.post.fields import fracture_energy
from forming.scene import (
    Body,
    Contact,
    Displacement,
    Interface,
    Linear,
    Scene,
    SelfContact,
    Stabilisation,
    Tool,
)
from forming.solver.stepping import StepControl

INFILL_MODULUS, INFILL_POISSON = 0.3, 0.0  # the paper's dummy infill, Table 3 [MPa]
FLANGE_MODULUS, FLANGE_POISSON = 4.0, 0.21  # the paper's dummy flanges, Table 3 [MPa]
INFILL_DENSITY = 5.0e-11  # the dummy infill, Table 3 [t/mm^3]
INFILL_FRACTURE, FLANGE_FRACTURE = 0.010, 0.067  # the dummies' fracture strains, Table 3


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
    fracture: bool = True  # walls fracture at Table 1's strain (False: elastic walls)
    fracture_strain: float = 0.067  # wall fracture strain (Table 1)
    fracture_energy: float = 7.4  # wall fracture energy G_f [N/mm] (estimate, materials.md)
    wall_deletion: Literal["all", "first", "half"] = "all"  # erodes: last point/first/half
    erosion: bool = True  # erode spent points (implicit: needs the stabilisation)
    damage_viscosity: float = 0.0  # viscous lag of the walls' damage [mm of platen travel]
    strain: float = 0.06  # nominal strain reached (0 < strain < 1)
    imperfection: float = 0.05  # largest imperfection move [mm]
    seed: int = 0  # seed of the imperfection
    buckling: bool = False  # also compute the linear buckling strains (platens bonded)
    stabilisation: float = 2e-4  # viscous stabilisation, dissipated energy fraction (0: none)
    platen: Literal["bonded", "contact"] = "bonded"  # top platen held to the walls or touching
    platen_friction: float = 0.36  # platen-wall friction when touching (tool-core, stated)
    # the touching platen's stick law: elastic slip (implicit: with the augmented stick
    # Newton fails in the first step of a quadratic wall's nine touching nodes) or augmented
    platen_stick: Literal["elastic_slip", "augmented"] = "elastic_slip"
    variant: Literal["original", "infill", "flange"] = "original"  # walls alone or with dummies
    flange_width: float = 1.0  # dummy flange width into the pores [mm] (our estimate)
    flange_thickness: float = 0.3  # dummy flange thickness [mm] (our estimate)
    # the dummies deleted at Table 3's fracture strains (explicit: nothing holds them after)
    dummy_deletion: bool = False
    max_step: float = 0.05  # largest load step (fraction of the stroke)
    # or transverse shear, or in-plane tension
    load: Literal["compression", "shear_x", "shear_y", "tension_x", "tension_y"] = "compression"
    self_contact: bool = True  # walls touch each other (explicit; implicit: stop there)


def patch_of(p: Params) -> HoneycombPatch:
    """The honeycomb patch the parameters describe."""
    cell = HoneycombCell(p.wall_length, None, p.wall_thickness, p.angle_deg, p.double_walls)
    return HoneycombPatch(cell, tuple(p.cells), p.height, p.size / 2, p.layers,
                          p.imperfection, p.seed, p.variant == "infill",
                          p.flange_width if p.variant == "flange" else 0.0,
                          p.flange_thickness)


def build(p: Params) -> Job:
    require(p, positive=("wall_length", "wall_thickness", "height", "size", "wall_modulus",
                         "flange_width", "flange_thickness", "fracture_strain",
                         "fracture_energy"),
            nonnegative=("imperfection", "stabilisation", "platen_friction",
                         "damage_viscosity"),
            fraction=("strain",))
    shear = p.load.startswith("shear")
    if shear and (p.platen != "bonded" or p.buckling):
        raise InputError("--set load", "transverse shear moves bonded platens "
                         "(platen=bonded, buckling=false)")
    patch = patch_of(p)
    if p.load in AXES:
        if p.variant != "original" or p.buckling or p.stabilisation <= 0:
            raise InputError("--set load", "in-plane tension pulls the walls alone, with the "
                             "stabilisation holding the free rigid motion (variant=original, "
                             "buckling=false, stabilisation > 0)")
        return _tension(p, patch)
    mesh = honeycomb_mesh(patch)
    material = _walls(p)
    stroke = p.strain * p.height
    split = p.variant != "original"  # the walls are one region of several
    walls = Body("walls", material, region="walls" if split else None, degree=2)
    bodies = [walls]
    # (body, its bottom face or None, its top face, its platen)
    parts = [("walls", "bottom", "top", "platen")]
    interfaces = ()
    if p.variant == "infill":  # Table 3's dummy infill, bonded to the walls
        infill = _dummy(IsotropicElasticity(INFILL_MODULUS, INFILL_POISSON), INFILL_DENSITY,
                        INFILL_FRACTURE, p.dummy_deletion)
        bodies.append(Body("infill", infill, region="infill", degree=1))
        parts.append(("infill", "infill_bottom", "infill_top", "platen_infill"))
        interfaces = (Interface("wall_infill", "walls", "infill", kind="bonded"),)
    elif p.variant == "flange":  # Table 3's dummy flanges on the walls' top edges
        flange = _dummy(IsotropicElasticity(FLANGE_MODULUS, FLANGE_POISSON),
                        WALL_DENSITY, FLANGE_FRACTURE, p.dummy_deletion)  # Table 3
        bodies.append(Body("flange", flange, region="flange", degree=2))
        parts.append(("flange", None, "flange_top", "platen_flange"))
        interfaces = (Interface("wall_flange", "walls", "flange", kind="bonded"),)
    bottoms = tuple(Displacement(b, bot, x=0.0, y=0.0, z=0.0, reaction=False)
                    for b, bot, _t, _p in parts if bot is not None)
    axis = {"compression": "z", "shear_x": "x", "shear_y": "y"}[p.load]
    moves = {"x": 0.0, "y": 0.0, "z": 0.0}
    moves[axis] = Linear(stroke if shear else -stroke)  # shear: the top moves sideways
    bonded = bottoms + tuple(Displacement(b, top, **moves) for b, _b, top, _p in parts)
    # the linear buckling analysis: the walls alone, both platens holding them (contact
    # and a bonded infill are not linear in the load)
    held = (bottoms[0], bonded[len(bottoms)])  # the walls' bottom and top
    buckling_strains = (_linear_buckling(Scene("meso_buckling", mesh, (walls,), held),
                                         p.strain) if p.buckling else None)
    if p.platen == "bonded":
        loading = dict(displacements=bonded)
        # a reaction is named by its face, and by body and face when there are several
        columns = [f"reaction_{top if len(parts) == 1 else f'{b}_{top}'}_{axis}_N"
                   for b, _bt, top, _p in parts]
        scale = 1.0 if shear else -1.0
    else:  # rigid platens that touch the wall edges (and infill) and may slide on them
        plane = Plane((0.0, 0.0, p.height), (0.0, 0.0, -1.0))
        loading = dict(displacements=bottoms,
                       tools=tuple(Tool(tool, plane, z=Linear(-stroke))
                                   for _b, _bt, _t, tool in parts),
                       contacts=tuple(Contact(b, top, tool, friction=p.platen_friction,
                                                  stick=p.platen_stick)
                                      for b, _bt, top, tool in parts))
        columns, scale = [f"force_{tool}_z_N" for _b, _bt, _t, tool in parts], 1.0
    # folds of the walls meet: contact between the walls' faces
    touching = ((SelfContact("walls", "sides", depth=0.5 * p.wall_thickness),)
                if p.self_contact else ())
    scene = Scene(
        name="meso_compression",
        mesh=mesh,
        bodies=tuple(bodies),
        interfaces=interfaces,
        self_contacts=touching,
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
        s = scale * sum(rec.column(c) for c in columns) / patch.footprint
        return e, s

    def metrics(rec, model) -> dict:
        e, s = nominal(rec)
        if shear:  # a transverse shear modulus (ASTM C273 with bonded platens)
            return {"relative_density": rho,
                    "shear_modulus_MPa": float(s[1] / e[1]) if len(e) > 1 else float("nan"),
                    "final_strain": float(e[-1]), "final_stress_MPa": float(s[-1]),
                    "fracture_energy_Nmm": float(rec.column("fracture_energy_Nmm")[-1])}
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
            "fracture_energy_Nmm": float(rec.column("fracture_energy_Nmm")[-1]),
        }
        if buckling_strains is not None:
            out["buckling_strain"] = float(buckling_strains[0])
        return out

    def probe(model) -> dict[str, float]:
        return {"fracture_energy_Nmm": fracture_energy(model.body)}

    def plots(rec, out: Path) -> list[Path]:
        e, s = nominal(rec)
        if shear:
            return [plot_curves(out / "stress_strain.png", [(e, s, "computed (meso)", "o-")],
                                "nominal shear strain", "nominal shear stress [MPa]",
                                f"Meso transverse shear ({p.load}), {p.cells[0]} x "
                                f"{p.cells[1]} cells")]
        if len(e) >= 3:  # the curve in the macro core's format (forming calibrate)
            CompressionCurve(tuple(e), tuple(np.maximum(s, 0.0)), "meso_compression").to_csv(
                out / CURVE_FILE, f"meso_compression {p.cells[0]} x {p.cells[1]} cells, "
                f"nominal strain and stress, every converged step")
        grid = np.linspace(0.0, p.strain, 100)
        macro = honeycomb_core("isotropic").curve
        walls_are = "fracturing" if p.fracture else "elastic"
        curves = [(e, s, f"computed (meso, {walls_are} walls)", "o-"),
                  (e, p.wall_modulus * rho * e, "E_s x relative density", "k--"),
                  (grid, macro.interpolate(grid), "macro model's C365 curve (estimate)", "k:")]
        return [plot_curves(out / "stress_strain.png", curves, "nominal strain",
                            "nominal stress [MPa]",
                            f"Meso compression, {p.cells[0]} x {p.cells[1]} cells")]

    def pictures(model, out: Path) -> list[Path]:
        return folded_walls_picture(model, out,
                                    f"Walls at {model.t * p.strain:.3g} nominal strain")

    return Job(
        scene=scene,
        steps=StepControl(initial=0.02, max=p.max_step, min=1e-5),
        newton=WALL_NEWTON,
        probe=probe, metrics=metrics, plots=plots, pictures=pictures,
        response=Response(columns[0], stroke, scale, "platen force on the walls"),
    )


def _walls(p: Params) -> FracturingSolid | ElasticSolid:
    """The cell walls' material: Table 1's cardboard, fracturing or elastic."""
    cardboard = IsotropicElasticity(p.wall_modulus, p.wall_poisson)
    if p.fracture:
        return FracturingSolid(cardboard, p.fracture_strain, p.fracture_energy,
                               erosion=p.erosion, viscosity=p.damage_viscosity,
                               element_deletion=p.wall_deletion,
                               density=WALL_DENSITY)
    return ElasticSolid(cardboard, density=WALL_DENSITY)


def _dummy(elasticity: IsotropicElasticity, density: float, strain: float,
           deletion: bool) -> FracturingSolid | ElasticSolid:
    """A dummy material of Table 3: elastic, or deleted at its fracture strain.

    With ``deletion`` a point is eroded once its largest principal strain in magnitude
    reaches ``strain``, in compression as in tension (the paper's element deletion;
    which strain its explicit code compared is not stated). The crack band's fracture
    energy is set so that tensile softening would take the band to ten times the
    fracture strain over a 1 mm element: deletion comes first.
    """
    if not deletion:
        return ElasticSolid(elasticity, density=density)
    energy = 5.0 * elasticity.E * strain * strain  # eps_u = 2 G_f / (E eps_f h) = 10 eps_f
    return FracturingSolid(elasticity, strain, energy, erosion=True, deletion_strain=strain,
                           density=density)


def _tension(p: Params, patch: HoneycombPatch) -> Job:
    """The patch pulled in its plane by its cut faces (``load=tension_x|tension_y``)."""
    held, stroke, column, section = inplane_loading(patch, p.load, p.strain)
    scene = Scene(name="meso_compression", mesh=honeycomb_mesh(patch),
                  bodies=(Body("walls", _walls(p), degree=2),), displacements=held,
                  stabilisation=Stabilisation(p.stabilisation))
    axis = AXES[p.load]
    name = "xy"[axis]
    modulus_ga, poisson_ga = gibson_ashby_inplane(patch.cell, axis, p.wall_modulus,
                                                  p.wall_poisson)
    total = f"reaction_cut_{name}max_{name}_N"
    whole = patch_box(patch.cell, *patch.cells)[2:][1 - axis] * patch.height

    def lattice(rec) -> tuple[np.ndarray, np.ndarray]:
        """The lattice's strain along the load and its stress (see forming.meso.inplane)."""
        nominal = rec.column("t") * p.strain
        strain = nominal if axis == 0 else rec.column("lattice_strain")
        return strain, rec.column(column) / section

    def first(values: np.ndarray) -> float:
        return float(values[1]) if len(values) > 1 else float("nan")

    def metrics(rec, model) -> dict:
        e, s = lattice(rec)
        nominal = rec.column("t") * p.strain
        return {"relative_density": patch.relative_density(),
                "inplane_modulus_MPa": first(s) / first(e),
                "gibson_ashby_inplane_MPa": modulus_ga,
                "inplane_poisson": -first(rec.column("lateral_strain")) / first(e),
                "gibson_ashby_poisson": poisson_ga,
                "patch_modulus_MPa": first(rec.column(total)) / whole / first(nominal),
                "final_strain": float(nominal[-1]), "final_stress_MPa": float(s[-1]),
                "stabilisation_energy_fraction": float(
                    rec.column("stabilisation_energy_Nmm")[-1]
                    / max(rec.column("internal_work_Nmm")[-1], 1e-300))}

    def plots(rec, out: Path) -> list[Path]:
        e, s = lattice(rec)
        return [plot_curves(out / "stress_strain.png",
                            [(e, s, "computed (meso, lattice measures)", "o-"),
                             (e, modulus_ga * e, "Gibson and Ashby (wall bending)", "k--")],
                            "strain of the lattice", "stress [MPa]",
                            f"Meso in-plane tension along {name}, {p.cells[0]} x "
                            f"{p.cells[1]} cells")]

    return Job(scene=scene, steps=StepControl(initial=p.max_step, max=p.max_step, min=1e-5),
               newton=WALL_NEWTON, plots=plots, metrics=metrics,
               probe=lambda model: lattice_strains(model.body, patch, p.load),
               response=Response(total, stroke, 1.0, "pull on the walls"))


def _linear_buckling(scene: Scene, strain: float) -> np.ndarray:
    """Nominal strains at which the patch as meshed (with its imperfection) buckles."""
    from forming.model import Model
    from forming.solver.buckling import buckling_modes
    from forming.solver.implicit import ImplicitSolver

    model = Model(scene)
    modes = buckling_modes(model, ImplicitSolver(model), n_modes=3)
    return modes.factors * strain


if __name__ == "__main__":
    main(build, Params, "meso_compression")
