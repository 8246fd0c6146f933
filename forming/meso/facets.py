"""Facet groups of a honeycomb patch's mesh (:func:`~forming.meso.honeycomb.honeycomb_mesh`).

Tags: the walls' ``bottom`` 1 and ``top`` 2, the infill's 4 and 5, the flanges' top 7;
the walls' side faces 3 (``wall_faces``), except those on the patch's rectangle, the
cuts (:data:`CUTS`): 9-12 at least one cell pitch from the rectangle's corners (the
``_inner`` groups), 13-16 nearer; the faces the walls share with the infill 6 and with
the flanges 8.
"""

from __future__ import annotations

import numpy as np
from dolfinx import mesh as dmesh

CUTS = {"cut_xmin": 9, "cut_xmax": 10, "cut_ymin": 11, "cut_ymax": 12}  # inner parts' tags
OUTER = 4  # a cut's part near the corners: its inner part's tag + OUTER
ALIGNED = 0.99  # a cut face's normal within 8 degrees of its side's normal


def cut_tags(msh, sides: np.ndarray, walls: np.ndarray,
             box: tuple[float, float, float, float], pitch: tuple[float, float],
             element_size: float) -> np.ndarray:
    """Tag of each side facet: a cut of the patch's rectangle (:data:`CUTS`) or 3.

    A cut face lies in a side of the rectangle ``box`` (x0, y0, width, depth): its
    midpoint is within a quarter element of it (the imperfection moves it by less), and
    it faces along that side's normal within 8 degrees (an inclined wall's face that
    crosses the side faces 30 degrees off it). ``walls`` marks the side facets of wall
    cells (an infill's faces are never cuts). A cut face is inner if it lies at least
    one cell ``pitch`` (along x, along y) from the ends of its side.
    """
    x0, y0, width, depth = box
    mid = dmesh.compute_midpoints(msh, 2, sides)
    geo = msh.geometry.x
    f2v = dmesh.entities_to_geometry(msh, 2, sides)  # corners of each quadrilateral face
    normal = np.cross(geo[f2v[:, 3]] - geo[f2v[:, 0]], geo[f2v[:, 2]] - geo[f2v[:, 1]])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
    near = 0.25 * element_size
    tags = np.full(len(sides), 3, dtype=np.int32)
    for (axis, plane), tag in zip([(0, x0), (0, x0 + width), (1, y0), (1, y0 + depth)],
                                  CUTS.values(), strict=True):
        on = (np.abs(mid[:, axis] - plane) < near) & (np.abs(normal[:, axis]) > ALIGNED)
        lateral, start, length = 1 - axis, (x0, y0)[1 - axis], (width, depth)[1 - axis]
        inner = np.abs(mid[:, lateral] - (start + length / 2)) <= length / 2 - pitch[lateral]
        tags[on & walls] = np.where(inner, tag, tag + OUTER)[on & walls]
    return tags


def facet_groups(msh, cell_region: np.ndarray, height: float,
                 box: tuple[float, float, float, float], pitch: tuple[float, float],
                 element_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Facet indices (sorted) and their group tags (the module's list).

    Args:
        msh: The patch's mesh.
        cell_region: Region of every local cell (1 walls, 2 infill, 3 flanges).
        height: The core's height (the bottom is z = 0, the top z = height).
        box: The patch's rectangle (x0, y0, width, depth).
        pitch: The cells' pitch along x and y.
        element_size: The in-plane element size.
    """
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    tol = 1e-6 * height
    bottom = dmesh.locate_entities_boundary(msh, tdim - 1, lambda p: np.abs(p[2]) < tol)
    top = dmesh.locate_entities_boundary(msh, tdim - 1, lambda p: np.abs(p[2] - height) < tol)
    boundary = dmesh.exterior_facet_indices(msh.topology)
    sides = np.setdiff1d(boundary, np.union1d(bottom, top))

    def owner(facets: np.ndarray) -> np.ndarray:
        return np.array([cell_region[f2c.links(f)[0]] for f in facets], dtype=np.int32)

    groups = [(bottom, np.array([1, 1, 4, 1])[owner(bottom)]),
              (top, np.array([2, 2, 5, 7])[owner(top)]),
              (sides, cut_tags(msh, sides, owner(sides) == 1, box, pitch, element_size))]
    n_facets = msh.topology.index_map(tdim - 1).size_local + \
        msh.topology.index_map(tdim - 1).num_ghosts
    shared = [f for f in range(n_facets) if len(cells := f2c.links(f)) == 2
              and cell_region[cells[0]] != cell_region[cells[1]]]
    other = [max(cell_region[f2c.links(f)]) for f in shared]  # the walls' partner
    groups.append((np.array(shared, dtype=np.int32),
                   np.where(np.array(other, dtype=np.int32) == 3, 8, 6)))
    facets = np.concatenate([g[0] for g in groups]).astype(np.int32)
    values = np.concatenate([g[1] for g in groups]).astype(np.int32)
    order = np.argsort(facets)
    return facets[order], values[order]


def group_names() -> tuple[dict[str, tuple[int, int]], dict[str, tuple[int, ...]]]:
    """Names of the cuts' facet groups: the inner parts, and each cut as a union."""
    names = {f"{name}_inner": (2, tag) for name, tag in CUTS.items()}
    unions = {name: (tag, tag + OUTER) for name, tag in CUTS.items()}
    return names, unions | {"sides": (3, *(t for u in unions.values() for t in u))}
