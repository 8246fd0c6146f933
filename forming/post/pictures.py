"""Pictures of the final state: sections and 3D views, gathered on rank 0.

Every function here is collective (it gathers the owned cells of every rank) and
writes its PNG on rank 0, returning the paths there (an empty list elsewhere).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from dolfinx import fem, mesh  # noqa: I001

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.bodies import SolidBody

# DOLFINx -> VTK vertex order of hexahedra and of their quadrilateral faces
_HEX_TO_VTK = [0, 1, 3, 2, 4, 5, 7, 6]
_QUAD_TO_POLYGON = [0, 1, 3, 2]


def _eval_at(u: fem.Function, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    if points.shape[0] == 0:
        return np.zeros((0, 3))
    return u.eval(points, cells.astype(np.int32))


def section_polygons(body: SolidBody, facet_tags, tag: int, axes: tuple[int, int],
                     cell_values: np.ndarray) -> tuple[list[np.ndarray], np.ndarray] | None:
    """Deformed in-plane polygons of the faces tagged ``tag``, with their cells' values.

    The faces are typically a symmetry plane. Gathered on rank 0 (None elsewhere).

    Args:
        body: The body.
        facet_tags: Its facet tags.
        tag: The tag of the section's faces.
        axes: The two in-plane coordinate axes, e.g. (0, 2).
        cell_values: One value per owned cell.
    """
    msh = body.mesh
    comm = msh.comm
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    n_owned = msh.topology.index_map(tdim - 1).size_local
    faces = facet_tags.find(tag)
    faces = faces[faces < n_owned]
    polys, vals = [], []
    if faces.size:
        coords = mesh.entities_to_geometry(msh, tdim - 1, faces)
        x = msh.geometry.x[coords]  # (n, k, 3)
        cells = np.array([f2c.links(f)[0] for f in faces])
        disp = _eval_at(body.u, x.reshape(-1, 3), np.repeat(cells, x.shape[1]))
        xd = x + disp.reshape(x.shape)
        order = _QUAD_TO_POLYGON if x.shape[1] == 4 else list(range(x.shape[1]))
        n_local_cells = body.n_local_cells
        for i, c in enumerate(cells):
            polys.append(xd[i][order][:, list(axes)])
            vals.append(cell_values[c] if c < n_local_cells else np.nan)
    gathered = comm.gather((polys, vals), root=0)
    if comm.rank != 0:
        return None
    all_polys = [p for ps, _ in gathered for p in ps]
    all_vals = np.array([v for _, vs in gathered for v in vs])
    return all_polys, all_vals


def deformed_grid(body: SolidBody, cell_values: dict[str, np.ndarray], scale: float = 1.0,
                  keep: np.ndarray | None = None):
    """A pyvista grid of the deformed body (owned cells of every rank) on rank 0.

    Args:
        body: The body (hexahedra or tetrahedra).
        cell_values: Arrays of one value per owned cell, attached as cell data.
        scale: Factor on the displacement (0: the reference configuration).
        keep: True at the owned cells to draw (None: all).
    """
    msh = body.mesh
    comm = msh.comm
    tdim = msh.topology.dim
    n = body.n_local_cells
    cells = np.arange(n, dtype=np.int32)
    geo = mesh.entities_to_geometry(msh, tdim, cells)
    x = msh.geometry.x[geo]
    disp = _eval_at(body.u, x.reshape(-1, 3), np.repeat(cells, x.shape[1]))
    xd = (x + scale * disp.reshape(x.shape))
    keep = np.ones(n, dtype=bool) if keep is None else np.asarray(keep[:n], dtype=bool)
    gathered = comm.gather((xd[keep], {k: v[:n][keep] for k, v in cell_values.items()}),
                           root=0)
    if comm.rank != 0:
        return None
    import pyvista as pv

    pts = np.concatenate([g[0] for g in gathered])
    k = pts.shape[1]
    if k == 8:
        pts = pts[:, _HEX_TO_VTK]
        ctype = pv.CellType.HEXAHEDRON
    else:
        ctype = pv.CellType.TETRA
    ncell = pts.shape[0]
    conn = np.hstack([np.full((ncell, 1), k), np.arange(ncell * k).reshape(ncell, k)]).ravel()
    grid = pv.UnstructuredGrid(conn, np.full(ncell, ctype, dtype=np.uint8),
                               pts.reshape(-1, 3))
    for key in cell_values:
        grid.cell_data[key] = np.concatenate([g[1][key] for g in gathered])
    return grid


def plastic_strain_pictures(model, out, section: str, title: str, tools_3d=None) -> list:
    """Section and 3D PNGs of the final volumetric plastic strain, with the tools drawn.

    The section is the symmetry face ``section``, mirrored. Collective: the files are
    written on rank 0 and returned there (empty elsewhere).
    """
    from forming.contact.render import render_3d, section_plot

    body = model.body
    evp = body.cell_average(body.plastic.evp)
    md = model.scene.mesh
    axis = 1 if section.endswith("ymin") else 0
    in_plane = (0, 2) if axis == 1 else (1, 2)
    sec = section_polygons(body, body.domain.facet_tags, md.facet_tag_ids(section)[0], in_plane,
                           evp)
    bar = "volumetric plastic strain [-]"
    grid = deformed_grid(body, {bar: evp})
    bounds, resolution = model.tool_bounds(), model.tool_resolution()  # collective
    if model.comm.rank != 0:
        return []
    out = Path(out)
    tools = [(tl.name, tl.shape, tl.offset(1.0)) for tl in model.scene.tools]
    shown = [(tl.shape, tl.offset(1.0)) for tl in model.scene.tools
             if tools_3d is None or tl.name in tools_3d]
    return [
        section_plot(out / "section_plastic_strain.png", sec[0], sec[1], tools,
                     (axis, 0.0), in_plane, label=bar,
                     title=f"{title}: section {'xy'[axis]} = 0 (mirrored)", mirror=True),
        render_3d(out / "plastic_strain_3d.png", grid, bar, shown, bounds, resolution,
                  title=title + _modelled(model)),
    ]


def shear_angle_picture(model, out, title: str, name: str = "shear_angle.png",
                        body_name: str | None = None) -> list:
    """Top view of a deformed fabric body coloured by its signed shear angle [deg].

    Args:
        model: The model.
        out: Output folder.
        title: Picture title.
        name: File name.
        body_name: The fabric body (default: the scene's first body).

    Collective: written on rank 0 and returned there (empty elsewhere).
    """
    from forming.contact.render import render_3d

    body = model.body if body_name is None else model.bodies[body_name]
    body.update_output()
    n = body.n_local_cells
    lo, hi = body.shear_range_deg()
    grid = deformed_grid(body, {"shear angle [deg]": body.shear_angle.x.array[:n].copy()})
    if model.comm.rank != 0:
        return []
    lim = max(abs(lo), abs(hi), 1e-6)
    return [render_3d(Path(out) / name, grid, "shear angle [deg]", [], (0, 1, 0, 1, 0, 1), 1.0,
                      title=title + _modelled(model), clim=(-lim, lim), view="xy",
                      cmap="coolwarm")]


def _modelled(model) -> str:
    """What part of the component a picture shows (a symmetric model's share)."""
    copies = model.scene.symmetry_copies
    share = {1: "", 2: "half", 4: "quarter", 8: "eighth"}[copies]
    return f"\n(the modelled {share}: the whole part is {copies} copies by symmetry)" if share \
        else ""
