"""Closest points of a contact region's nodes on a surface-mesh tool, as nodal fields.

A :class:`~forming.contact.surface.SurfaceTool` has no distance in UFL. Its contact
writes the gap at a node as ``g = n . (p - c)``, ``p = x + u - offset``, with the
closest point ``c`` and the outward normal ``n`` held in P1 fields that
:class:`ClosestPoints` refreshes from the current configuration before every residual
and Jacobian. ``g`` is then the exact signed distance of the current iterate, and its
derivative with ``c`` and ``n`` held is the exact one, ``n``. The traction's direction
is written ``m + K (p - a)`` with ``a`` the point the query was made at (so it equals
the smoothed normal ``m`` at the iterate) and ``K = dm/dx`` from the query
(:mod:`forming.contact.closest`). So the Jacobian is the exact derivative of the
residual everywhere (docs/theory.md, section 9).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem


class ClosestPoints:
    """Closest point and normal of every node of a region on a surface tool.

    Args:
        shape: The tool (:class:`~forming.contact.surface.SurfaceTool`).
        body: The body whose region touches it.
        facets: The region's facets on the body's mesh.
    """

    def __init__(self, shape, body, facets: np.ndarray):
        self.shape = shape
        self.body = body
        V = body.V
        Wv = fem.functionspace(body.mesh, ("Lagrange", 1, (3,)))
        self.closest = fem.Function(Wv, name="closest_point")
        self.normal = fem.Function(Wv, name="tool_normal")
        self.direction_at = fem.Function(Wv, name="traction_direction")
        self.anchor = fem.Function(Wv, name="query_point")
        Wt = fem.functionspace(body.mesh, ("Lagrange", 1, (3, 3)))
        self.rotation = fem.Function(Wt, name="normal_derivative")
        nodes = fem.locate_dofs_topological(V, 2, facets)  # owned and ghost nodes
        imap = V.dofmap.index_map
        blocks = np.empty(imap.size_local + imap.num_ghosts, dtype=np.int64)
        blocks[V.dofmap.list] = Wv.dofmap.list
        self._nodes = nodes.astype(np.int64)
        self._blocks = blocks[self._nodes]
        self._x0 = V.tabulate_dof_coordinates()[self._nodes]
        self._last = np.full((len(self._nodes), 3), np.nan)  # points of the last query
        self._tracker = shape.tracker()

    def repair(self) -> None:
        """Pair the nodes with their closest facets again (tree search) at the next update."""
        self._tracker.repair()
        self._last[:] = np.nan

    def update(self, offset: np.ndarray) -> None:
        """Closest points of the current configuration, the tool moved by ``offset``.

        Nothing is queried when no node has moved since the last call (the Jacobian
        after a residual at the same iterate).
        """
        points = self._x0 + self.body.u.x.array.reshape(-1, 3)[self._nodes] - offset
        if np.array_equal(points, self._last):
            return
        self._last = points
        q = self._tracker.query(points)
        self.closest.x.array.reshape(-1, 3)[self._blocks] = q.point
        self.normal.x.array.reshape(-1, 3)[self._blocks] = q.normal
        self.direction_at.x.array.reshape(-1, 3)[self._blocks] = q.direction
        self.anchor.x.array.reshape(-1, 3)[self._blocks] = points
        self.rotation.x.array.reshape(-1, 9)[self._blocks] = q.rotation.reshape(-1, 9)

    def direction(self, p):
        """The traction's direction at the UFL point ``p``: ``m + K (p - a)``."""
        return self.direction_at + ufl.dot(self.rotation, p - self.anchor)
