"""Elements folded at their corners: the trilinear map's determinant at its vertices.

A hexahedron can fold near one of its nodes (a punch's corner pressing one column of a
crushable core into the layer below) while its quadrature points, one, two or eight
inside it, all keep a positive det F. The map's determinant at the 8 vertices sees it
(docs/theory.md, section 12, "Folded elements").
"""

from __future__ import annotations

import basix
import numpy as np

_P1 = basix.create_element(basix.ElementFamily.P, basix.CellType.hexahedron, 1)
_DN = _P1.tabulate(1, _P1.points)[1:4, :, :, 0]  # (3, vertex, node): d N / d xi


def corner_dets(x: np.ndarray) -> np.ndarray:
    """Determinant of each trilinear element's map at its 8 vertices.

    Args:
        x: (n_cells, 8, 3) node coordinates in basix's vertex order.

    Returns:
        (n_cells, 8) det of d x / d xi at the vertices.
    """
    # the map's derivative along each reference axis at each vertex: (n_cells, 8, 3)
    d0, d1, d2 = (np.matmul(_DN[k], x) for k in range(3))
    return np.einsum("cqi,cqi->cq", d0, np.cross(d1, d2))


class CornerWatch:
    """The smallest corner determinant of a body's P1 hexahedra, over its reference one.

    Args:
        nodes: (n_cells, 8) node (block) indices of the rank's owned cells.
        x: (n_cells, 8, 3) their reference coordinates.
    """

    def __init__(self, nodes: np.ndarray, x: np.ndarray):
        self.nodes = nodes
        self.x = x
        self.det0 = corner_dets(x)

    def smallest(self, u: np.ndarray) -> float:
        """This rank's smallest ratio at displacement ``u`` (3 per node); inf without cells."""
        current = corner_dets(self.x + u.reshape(-1, 3)[self.nodes])
        return float(np.min(current / self.det0, initial=np.inf))
