"""Measurements and pictures of cell walls: wall strain against fracture, folded walls."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.post.pictures import deformed_grid


def wall_strain_extremes(body) -> tuple[float, float]:
    """Largest and smallest principal Green-Lagrange strain over the walls (collective).

    Evaluated at the quadrature points of the owned cells: a tensile value above the
    wall material's fracture strain (0.067 for the paper's cardboard) is where a wall
    would have torn.
    """
    F = body.deformation_gradient()
    E = 0.5 * (F.T * F - ufl.Identity(3))
    points = body.QS.element.interpolation_points
    values = fem.Expression(ufl.as_vector([E[i, j] for i in range(3) for j in range(3)]),
                            points).eval(body.mesh, body.point_cells)
    eig = np.linalg.eigvalsh(values.reshape(-1, 3, 3)) if values.size else np.zeros((1, 3))
    comm = body.mesh.comm
    return (comm.allreduce(float(eig[:, 2].max()), op=MPI.MAX),
            comm.allreduce(float(eig[:, 0].min()), op=MPI.MIN))


def folded_walls_picture(model, out: Path, title: str, name: str = "folded_walls.png") -> list:
    """3D view of the deformed walls coloured by their sideways (in-plane) displacement.

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
    grid = deformed_grid(body, {label: np.linalg.norm(u[:, :2], axis=1)})
    if model.comm.rank != 0:
        return []
    return [render_3d(Path(out) / name, grid, label, [], (0, 1, 0, 1, 0, 1), 1.0, title=title)]
