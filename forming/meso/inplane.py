"""In-plane tension of a honeycomb patch: its loading, its lattice moduli, Gibson and Ashby's.

The patch's rectangle (:func:`~forming.meso.honeycomb.patch_box`) cuts the ribbon walls
square at their middles (the sides x = const) and the inclined walls at their middles
(the sides y = const). Which of these cuts carry the infinite lattice's own condition
follows from its mirror symmetries (x -> -x about every cell's centre, y -> -y along every
ribbon wall):

* Pulled along x (``tension_x``), the ribbon walls stretch and the inclined walls bend.
  The sides x = const are mirror planes: a cut face there stays plane and slides freely
  on it, so prescribing its normal displacement alone is the lattice's condition, and
  the strain is the stroke over the width. The sides y = const are not: there the
  lattice's inclined walls carry a force along x, the patch's cut walls dangle free, and
  the chains of walls next to them are softer. The stress is therefore taken from the
  reaction on the inner part of the pulled face (``cut_xmax_inner``: the ribbon walls at
  least a pitch from the free sides; ``cells[1] >= 3``), over the depth those walls
  stand for.
* Pulled along y (``tension_y``), the inclined walls bend and the ribbon walls translate
  without bending: they carry no moment and no force along x (mirror y -> -y, and the
  translation along y between equal walls). The free sides x = const, which cut ribbon
  walls at their middles, are therefore the lattice's condition, and the stress is the
  whole reaction over the width. The pulled faces y = const are not: a uniform normal
  displacement holds the cut inclined walls from rotating, which stiffens the walls
  near both ends. The strain is therefore measured inside, from the ribbon walls, which
  move as rigid markers of the lattice's deformation.

Either way the strains measured inside (along y, and across the load: the Poisson
ratio) come from the mean displacements of the ribbon walls in the inner rows (at least
a pitch from the sides y = const), fitted linearly against their positions. Every
other face is free; the walls' bottom edges are held in z only. Nothing holds the
patch along the lateral direction: the run's viscous stabilisation takes that rigid
motion (it carries no load).
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI

from forming.errors import InputError
from forming.meso.honeycomb import HoneycombCell, HoneycombPatch, patch_box
from forming.scene import Displacement, Linear

AXES = {"tension_x": 0, "tension_y": 1}


def gibson_ashby_inplane(cell: HoneycombCell, axis: int, wall_modulus: float,
                         wall_poisson: float) -> tuple[float, float]:
    """Gibson and Ashby's in-plane Young's modulus and Poisson ratio along ``axis``.

    Bending of the inclined walls only (Gibson and Ashby, Cellular Solids, 2nd ed., eqs.
    4.7-4.10), with the plate modulus E_s / (1 - nu_s^2): the walls are plates as tall as
    the core, bent about lines along its axis. x is the ribbon (along the ribbon walls,
    the book's X2), y across it (the book's X1); the double ribbon walls only stretch or
    translate, so their thickness does not enter. The walls' lengths are between
    junction centres: the junctions' own stiffness is left out.

    Returns:
        The modulus [MPa] and the Poisson ratio (the lateral contraction over the strain).
    """
    t_l = cell.wall_thickness / cell.wall_length
    h_l = cell.h / cell.wall_length
    theta = math.radians(cell.angle_deg)
    s, c = math.sin(theta), math.cos(theta)
    plate = wall_modulus / (1.0 - wall_poisson**2) * t_l**3
    if axis == 0:
        return plate * (h_l + s) / c**3, (h_l + s) * s / c**2
    return plate * c / ((h_l + s) * s**2), c**2 / ((h_l + s) * s)


def check_patch(patch: HoneycombPatch, load: str) -> None:
    """Refuse a patch too small for the lattice measures of ``load``.

    Raises:
        InputError: Fewer than 3 cells along y (no inner rows of ribbon walls), or,
            pulled along y, fewer than 2 cells along x (one column of ribbon walls).
    """
    nx, ny = patch.cells
    if ny < 3:
        raise InputError("--set cells", f"in-plane tension needs 3 or more cells along y "
                         f"(inner rows of ribbon walls, away from the sides y = const), "
                         f"got {ny}")
    if AXES[load] == 1 and nx < 2:
        raise InputError("--set cells", f"in-plane tension along y needs 2 or more cells "
                         f"along x (two columns of ribbon walls), got {nx}")


def inplane_loading(patch: HoneycombPatch, load: str, strain: float
                    ) -> tuple[tuple[Displacement, ...], float, str, float]:
    """The displacements of an in-plane tension run, its stroke and its stress's reaction.

    Args:
        patch: The honeycomb patch.
        load: ``tension_x`` or ``tension_y``.
        strain: Nominal strain at the end of the run.

    Returns:
        The displacements (the far cut face moves by the stroke; pulled along x its inner
        part is held again, to record its own reaction), the stroke [mm], the name of the
        reaction column whose force gives the lattice's stress, and the section that
        force acts on [mm^2].
    """
    check_patch(patch, load)
    axis = AXES[load]
    _x0, _y0, width, depth = patch_box(patch.cell, *patch.cells)
    name = "xy"[axis]
    stroke = strain * (width, depth)[axis]
    pull = {name: Linear(stroke)}
    held = [Displacement("walls", f"cut_{name}min", reaction=False, **{name: 0.0}),
            Displacement("walls", f"cut_{name}max", **pull),
            Displacement("walls", "bottom", z=0.0, reaction=False)]
    if axis == 0:
        held.append(Displacement("walls", "cut_xmax_inner", **pull))
        section = (patch.cells[1] - 2) * patch.cell.pitch[1] * patch.height
        return tuple(held), stroke, "reaction_cut_xmax_inner_x_N", section
    return tuple(held), stroke, "reaction_cut_ymax_y_N", width * patch.height


def ribbon_walls(patch: HoneycombPatch) -> np.ndarray:
    """Middles (x, y) of the ribbon walls in the patch's rectangle (half walls included)."""
    cell = patch.cell
    px, py = cell.pitch
    x0, y0, width, depth = patch_box(cell, *patch.cells)
    out = [(i * px, (k + 0.5 * ((i + 1) % 2)) * py)
           for i in range(patch.cells[0] + 1) for k in range(patch.cells[1] + 2)]
    return np.array([(x, y) for x, y in out if y0 < y < y0 + depth and x0 <= x <= x0 + width])


def ribbon_means(body, patch: HoneycombPatch) -> tuple[np.ndarray, np.ndarray]:
    """Reference position and displacement (x, y) of every ribbon wall, node means (collective).

    A ribbon wall's nodes are those within its thickness (and a tenth of a single wall
    for the imperfection) of its mid-plane and at least its thickness from the
    junctions at its ends.
    """
    cell = patch.cell
    walls = ribbon_walls(patch)
    n_owned = body.V.dofmap.index_map.size_local
    x = body.V.tabulate_dof_coordinates()[:n_owned, :2]
    u = body.u.x.array.reshape(-1, 3)[:n_owned, :2]
    half = cell.ribbon_thickness / 2 + 0.1 * cell.wall_thickness
    reach = cell.h / 2 - cell.ribbon_thickness
    sums = np.zeros((len(walls), 5))
    for k, (wx, wy) in enumerate(walls):
        on = (np.abs(x[:, 1] - wy) <= half) & (np.abs(x[:, 0] - wx) <= reach)
        sums[k] = [*x[on].sum(axis=0), *u[on].sum(axis=0), on.sum()]
    body.mesh.comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
    count = np.maximum(sums[:, 4:5], 1.0)
    return sums[:, 0:2] / count, sums[:, 2:4] / count


def _slope(position: np.ndarray, value: np.ndarray) -> float:
    """Least-squares slope of ``value`` against ``position``."""
    return float(np.polyfit(position, value, 1)[0])


def lattice_strains(body, patch: HoneycombPatch, load: str) -> dict[str, float]:
    """The lattice's strains along and across the load, from the ribbon walls (collective).

    Only the rows of ribbon walls at least a pitch from the sides y = const are used:
    pulled along x those sides are free, pulled along y they are held square; either
    way the rows next to them are not the lattice's. Pulled along x the stroke's strain
    along it is exact (see the module), so only the lateral strain is measured.

    Returns:
        ``lattice_strain`` along the load (pulled along x: nan, the stroke gives it) and
        ``lateral_strain`` across it.
    """
    x, u = ribbon_means(body, patch)
    _x0, y0, _w, depth = patch_box(patch.cell, *patch.cells)
    inner = np.abs(x[:, 1] - (y0 + depth / 2)) <= depth / 2 - patch.cell.pitch[1]
    x, u = x[inner], u[inner]
    if AXES[load] == 0:
        return {"lattice_strain": float("nan"), "lateral_strain": _slope(x[:, 1], u[:, 1])}
    return {"lattice_strain": _slope(x[:, 1], u[:, 1]),
            "lateral_strain": _slope(x[:, 0], u[:, 0])}
