"""The formed blank's faces, gathered on rank 0, and what is measured on them.

Each body is gathered as a pyvista grid twice, in its reference and its deformed
configuration (:func:`forming.post.deformed_grid`, collective). Its boundary faces are
then sorted by their outward normal: the faces looking up (a normal's z above
``FACING``), looking down, and the lateral ones. Distances to a tool or to another face
are VTK's implicit distances to a triangulated surface (signed by its normals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forming.post.pictures import deformed_grid

FACING = 0.3  # a face looks up (down) when its unit normal's z exceeds this (is below -)


@dataclass(frozen=True)
class Faces:
    """Boundary faces of a body, both configurations (rank 0).

    Attributes:
        polygons: Deformed face corners (n, 4, 3).
        reference: Reference face corners (n, 4, 3).
        normals: Deformed outward unit normals (n, 3).
        areas: Deformed areas (n,).
        cells: The cell (index into the gathered cell values) of each face (n,).
        values: The gathered cell values (name -> (cells,)).
    """

    polygons: np.ndarray
    reference: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    cells: np.ndarray
    values: dict[str, np.ndarray]

    @property
    def centres(self) -> np.ndarray:
        """Deformed face centres (n, 3)."""
        return self.polygons.mean(axis=1)

    @property
    def reference_centres(self) -> np.ndarray:
        """Reference face centres (n, 3)."""
        return self.reference.mean(axis=1)

    def select(self, which: np.ndarray) -> Faces:
        """The faces where ``which`` is true."""
        return Faces(self.polygons[which], self.reference[which], self.normals[which],
                     self.areas[which], self.cells[which], self.values)

    def up(self) -> Faces:
        """The faces looking up."""
        return self.select(self.normals[:, 2] > FACING)

    def down(self) -> Faces:
        """The faces looking down."""
        return self.select(self.normals[:, 2] < -FACING)

    def lateral(self) -> Faces:
        """The faces looking sideways (the blank's edge and symmetry planes)."""
        return self.select(np.abs(self.normals[:, 2]) <= FACING)

    def value(self, name: str) -> np.ndarray:
        """A cell value at each face (its cell's)."""
        return self.values[name][self.cells]

    def midway(self, other: Faces) -> np.ndarray:
        """Deformed corners (n, 4, 3) halfway between these faces and ``other``.

        For an extruded body's top and bottom: each corner is averaged with the corner of
        ``other`` nearest it in reference plan position (the same node column).
        """
        mine = self.reference[:, :, :2].reshape(-1, 2)
        theirs = other.reference[:, :, :2].reshape(-1, 2)
        nearest = np.array([np.argmin(np.sum((theirs - p) ** 2, axis=1)) for p in mine])
        below = other.polygons.reshape(-1, 3)[nearest].reshape(self.polygons.shape)
        return 0.5 * (self.polygons + below)

    def polydata(self):
        """The deformed faces as a triangulated :class:`pyvista.PolyData`."""
        import pyvista as pv

        n = len(self.polygons)
        cells = np.hstack([np.full((n, 1), 4), np.arange(4 * n).reshape(n, 4)]).ravel()
        return pv.PolyData(self.polygons.reshape(-1, 3), cells).triangulate()


def boundary_faces(body, cell_values: dict[str, np.ndarray]) -> Faces | None:
    """The boundary faces of a hexahedral body with its cell values (collective; rank 0)."""
    current = deformed_grid(body, cell_values)
    reference = deformed_grid(body, {}, scale=0.0)
    if current is None:
        return None
    ids, corners = _surface_quads(current)
    pts = current.points[corners]
    ref = reference.points[corners]
    n = np.cross(pts[:, 2] - pts[:, 0], pts[:, 3] - pts[:, 1])
    area = 0.5 * np.linalg.norm(n, axis=1)
    n /= np.maximum(2.0 * area, 1e-300)[:, None]
    centre = current.cell_centers().points[ids]
    outward = np.einsum("ij,ij->i", n, pts.mean(axis=1) - centre) >= 0.0
    n[~outward] *= -1.0
    values = {k: np.asarray(current.cell_data[k]) for k in cell_values}
    return Faces(pts, ref, n, area, ids, values)


_HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5],
                       [2, 3, 7, 6], [3, 0, 4, 7]])  # VTK hexahedron's faces


def _surface_quads(grid) -> tuple[np.ndarray, np.ndarray]:
    """Cell index and point indices (n, 4) of the faces that belong to one cell only."""
    conn = grid.cells_dict
    hexes = np.asarray(next(iter(conn.values())))
    faces = hexes[:, _HEX_FACES].reshape(-1, 4)
    owner = np.repeat(np.arange(len(hexes)), 6)
    # the gathered grid repeats shared points: faces match by their corner positions
    key = np.round(grid.points / (1e-9 * max(float(np.ptp(grid.points)), 1.0))).astype(np.int64)
    _u, point_id = np.unique(key, axis=0, return_inverse=True)
    sorted_corners = np.sort(point_id.reshape(-1)[faces], axis=1)
    _u, inverse, counts = np.unique(sorted_corners, axis=0, return_inverse=True,
                                    return_counts=True)
    single = counts[inverse.reshape(-1)] == 1
    return owner[single], faces[single]


def implicit_distance(points: np.ndarray, surface) -> np.ndarray:
    """Signed distance of points (n, 3) to a triangulated surface (VTK, by its normals)."""
    import pyvista as pv

    cloud = pv.PolyData(np.asarray(points, dtype=float))
    return np.asarray(cloud.compute_implicit_distance(surface)["implicit_distance"])
