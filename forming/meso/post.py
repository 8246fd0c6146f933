"""Measurements and pictures of cell walls: wall strain against fracture, folded walls."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import ufl
from mpi4py import MPI

from forming import compat
from forming.post.pictures import deformed_grid


def wall_strain_extremes(body) -> tuple[float, float]:
    """Largest and smallest principal Green-Lagrange strain over the walls (collective).

    Evaluated at the quadrature points of the owned cells: a tensile value above the
    wall material's fracture strain (0.067 for the paper's cardboard) is where a wall
    would have torn (elastic walls); fracturing walls leave out their eroded points.
    """
    F = body.deformation_gradient()
    E = 0.5 * (F.T * F - ufl.Identity(3))
    points = body.QS.element.interpolation_points
    values = compat.expression(ufl.as_vector([E[i, j] for i in range(3) for j in range(3)]),
                               points).eval(body.mesh, body.point_cells)
    values = values.reshape(-1, 3, 3)[body.active_points()]
    eig = np.linalg.eigvalsh(values) if values.size else np.zeros((1, 3))
    comm = body.mesh.comm
    return (comm.allreduce(float(eig[:, 2].max()), op=MPI.MAX),
            comm.allreduce(float(eig[:, 0].min()), op=MPI.MIN))


def folded_walls_picture(model, out: Path, title: str, name: str = "folded_walls.png") -> list:
    """3D view of the deformed walls coloured by their sideways (in-plane) displacement.

    Walls that fracture get a second view, ``damaged_walls.png``, coloured by the
    largest damage in each cell. Cells whose every point has eroded are not drawn: they
    carry nothing, and a node that only they hold drifts off with the speed it had (an
    explicit code's deleted elements are not drawn either).

    Collective: written on rank 0 and returned there (empty elsewhere).
    """
    from forming.contact.render import render_3d

    body = model.body
    msh = body.mesh
    n = body.n_local_cells
    centres = np.zeros((n, 3))
    if n:
        from dolfinx import mesh as dmesh

        geo = dmesh.entities_to_geometry(msh, msh.topology.dim, np.arange(n, dtype=np.int32))
        centres = msh.geometry.x[geo].mean(axis=1)
    u = body.u.eval(centres, np.arange(n, dtype=np.int32)) if n else np.zeros((0, 3))
    label = "sideways displacement [mm]"
    fields = {label: np.linalg.norm(u[:, :2], axis=1)}
    damage = body.damage()
    if damage is not None:  # the worst point of each cell
        fields["damage"] = damage.reshape(n, -1).max(axis=1) if n else np.zeros(0)
    keep = body.live_cells() if damage is not None else None
    if keep is not None and model.comm.allreduce(int(np.count_nonzero(~keep))):
        title = f"{title} (eroded cells not drawn)"
    grid = deformed_grid(body, fields, keep=keep)
    if model.comm.rank != 0:
        return []
    out = Path(out)
    paths = [render_3d(out / name, grid, label, [], (0, 1, 0, 1, 0, 1), 1.0, title=title)]
    if damage is not None:
        paths.append(render_3d(out / "damaged_walls.png", grid, "damage", [],
                               (0, 1, 0, 1, 0, 1), 1.0, title=f"{title}: damage"))
    return paths


def wall_columns(body, height: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The walls' top and bottom nodes paired along the cell axis (collective).

    The walls are prisms along z whose imperfection vanishes at both ends, so each node
    of the top face (z = ``height``) has one of the bottom face (z = 0) at the same
    reference (x, y). Gathered on every rank.

    Returns:
        (reference (x, y) (n, 2), current z of the top node (n,), current z of the
        bottom node (n,)) per column.
    """
    V = body.V
    n = V.dofmap.index_map.size_local
    xr = V.tabulate_dof_coordinates()[:n]
    z = xr[:, 2] + body.u.x.array.reshape(-1, 3)[:n, 2]
    tol = 1e-6 * height

    def gathered(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        local = np.column_stack([xr[mask, :2], z[mask]])
        rows = np.concatenate(body.mesh.comm.allgather(local))
        rows = rows[np.lexsort((np.round(rows[:, 1], 6), np.round(rows[:, 0], 6)))]
        return rows[:, :2], rows[:, 2]

    top_xy, top_z = gathered(np.abs(xr[:, 2] - height) < tol)
    bottom_xy, bottom_z = gathered(np.abs(xr[:, 2]) < tol)
    if top_xy.shape != bottom_xy.shape or not np.allclose(top_xy, bottom_xy, atol=1e-6):
        raise ValueError("the walls' top and bottom nodes do not pair along z")
    return top_xy, top_z, bottom_z


def held_nodes(body) -> np.ndarray:
    """True at the owned nodes (blocks of ``body.V``) that a live cell holds (collective).

    A node that only eroded cells hold is a floating fragment: it keeps its mass and
    drifts, and is left out of what the walls' shape is measured by. Counts of live cells
    are summed over the ranks that share a node.
    """
    from dolfinx import la

    V = body.V
    imap = V.dofmap.index_map
    count = la.vector(imap, 1)
    cells = body.point_cells
    if len(cells):
        np.add.at(count.array, V.dofmap.list[cells[body.live_cells()]].ravel(), 1.0)
    count.scatter_reverse(la.InsertMode.add)
    return count.array[: imap.size_local] > 0.5


def damaged_volume(body, where) -> tuple[float, float]:
    """The walls' volume with damage above 0.5 (collective).

    Args:
        body: The walls (a fracturing solid).
        where: Maps the (n, 2) plan midpoints of the owned cells to a boolean mask.

    Returns:
        (its share of the walls' volume, the share of it in the cells ``where`` picks).
    """
    from dolfinx.mesh import compute_midpoints

    from forming.post.fields import PointIntegral

    hit = body.damage() > 0.5
    cells = body.point_cells
    mid = compute_midpoints(body.mesh, 3, cells.astype(np.int32))[:, :2]
    picked = np.repeat(where(mid), hit.size // max(len(cells), 1))
    integral = PointIntegral(body)
    total, volume = integral(hit.astype(float)), integral(np.ones(hit.size))
    return total / volume, integral((hit & picked).astype(float)) / total if total > 0 else 0.0
