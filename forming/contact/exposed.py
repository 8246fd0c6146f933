"""The surface a tool meets on a body whose elements erode: what erosion uncovers joins it.

A tool contact acts on a surface group of the body (the walls' top edges under a punch).
Once the elements under the tool fracture and erode, that group lies on cells that carry
nothing, and the faces below, which the erosion uncovered, belong to no group: without
more, the tool passes through the body. Explicit codes that delete failed elements let
their contact follow the deletion (Abaqus/Explicit's general contact includes the
interior faces of element-based surfaces). :class:`ExposedSurface` does the same for a
node-by-node tool contact: the surface is the group's faces on live cells and every face
between a live and an eroded cell, and the nodal areas are integrated over it with the
contact's nodal rule.

A cell is eroded when none of its points carries stress
(:meth:`~forming.bodies.solid.SolidBody.active_points`). The surface is rebuilt when the
number of eroded cells changes; the rebuild is collective (the erosion of ghost cells is
scattered from their owners).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, la  # noqa: I001

from forming.vectors import assembled


class ExposedSurface:
    """The faces of a surface group on live cells, and the faces erosion has uncovered.

    Args:
        body: The body (a solid whose material erodes; its own mesh and space are used).
        facets: The group's facets on the body's own mesh (local indices).
        metadata: The quadrature metadata of the contact's nodal rule.
    """

    def __init__(self, body, facets: np.ndarray, metadata: dict[str, object]):
        self.body = body
        msh = body.mesh
        topo = msh.topology
        topo.create_connectivity(3, 2)
        topo.create_connectivity(2, 3)
        cmap = topo.index_map(3)
        self._n_owned = cmap.size_local
        c2f = topo.connectivity(3, 2)
        per_cell = len(c2f.links(0)) if cmap.size_local + cmap.num_ghosts else 0
        own = c2f.array.reshape(-1, max(per_cell, 1))[: self._n_owned]
        f2c = topo.connectivity(2, 3)
        off, arr = f2c.offsets, f2c.array
        first = arr[off[:-1]]
        second = np.where(np.diff(off) == 2, arr[np.minimum(off[:-1] + 1, len(arr) - 1)], -1)
        cells = np.arange(self._n_owned)[:, None]
        # the cell across each face of every owned cell (-1: none, an exterior face)
        self._across = np.where(first[own] == cells, second[own], first[own])
        group = np.zeros(len(off) - 1, dtype=bool)
        group[facets] = True
        self._in_group = group[own]
        self._dead = la.vector(cmap, 1)
        self._w = ufl.TestFunction(body.V)
        self._ones = ufl.as_vector([1.0, 1.0, 1.0])
        self._metadata = metadata
        self._area = fem.Function(body.V)
        self.eroded = -1  # eroded owned cells when the surface was last built

    def _eroded_cells(self) -> np.ndarray:
        """True at every owned cell (by local index) none of whose points carries stress."""
        body = self.body
        dead = np.zeros(self._n_owned, dtype=bool)
        cells = body.point_cells
        if len(cells):
            dead[cells] = ~body.live_cells()
        return dead

    def stale(self) -> bool:
        """True when this rank's erosion changed since the surface was built (local)."""
        return int(np.count_nonzero(self._eroded_cells())) != self.eroded

    def entities(self) -> np.ndarray:
        """The surface's faces as (owned live cell, local face) rows (collective)."""
        dead = self._eroded_cells()
        self.eroded = int(np.count_nonzero(dead))
        flags = self._dead.array
        flags[:] = 0.0
        flags[: self._n_owned] = dead
        self._dead.scatter_forward()
        across = self._across
        uncovered = (across >= 0) & (flags[np.maximum(across, 0)] > 0.5)
        keep = (self._in_group | uncovered) & ~dead[:, None]
        cell, face = np.nonzero(keep)
        return np.column_stack([cell, face]).astype(np.int32)

    def areas(self, nodes: np.ndarray) -> np.ndarray:
        """Each node's share of the surface's area [mm^2] (collective).

        Args:
            nodes: Owned nodes (block indices of the body's displacement space).
        """
        ds = ufl.Measure("ds", domain=self.body.mesh,
                         subdomain_data=[(1, self.entities().ravel())], subdomain_id=1,
                         metadata=self._metadata)
        assembled(fem.form(ufl.dot(self._ones, self._w) * ds), self._area)
        return self._area.x.array[3 * nodes].copy()
