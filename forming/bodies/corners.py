"""Elements folded at their corners: the trilinear map's determinant at its vertices.

A hexahedron can fold near one of its nodes (a punch's corner pressing one column of a
crushable core into the layer below) while its quadrature points, one, two or eight
inside it, all keep a positive det F. The map's determinant at the 8 vertices sees it
(docs/theory.md, section 12, "Folded elements"). :class:`DistortionControl` keeps
the hourglass-controlled elements of an explicit run from folding.
"""

from __future__ import annotations

import basix
import numba
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


@numba.njit(cache=True)
def corner_penalty(u, nodes, x, edges, det0, ratio, k_el, wave2, f, energy):
    """Add the distortion control's forces to ``f``; its energy; its frequency bound.

    At each corner ``k`` of an element the ratio ``r = det A_k / det A_k,0`` of its map's
    determinant to the reference one is held above ``ratio`` by the energy
    ``W = k_el / 2 ((ratio - r) / ratio)^2`` while ``r < ratio`` (0 above). On the
    reference cube [0, 1]^3 the map's derivative at a corner has the corner's three
    edges as columns, ``A_k e_j = s_j (x_n(j) - x_k)`` (``n(j)`` the neighbour along
    axis ``j``, ``s_j = +1`` or ``-1`` as the corner is at 0 or 1 on it), so
    ``d det A_k / d x_n(j) = s_j cof(A_k) e_j`` and the corner node takes minus their sum.

    Args:
        u: Nodal displacements, 3 per node.
        nodes: (n_cells, 8) node of each element node.
        x: (n_cells, 8, 3) reference node coordinates.
        edges: (8, 6) per corner, the neighbour along each axis, then the three signs.
        det0: (n_cells, 8) reference corner determinants.
        ratio: Corner ratio below which the penalty acts.
        k_el: (n_cells,) penalty stiffness of each element [N mm].
        wave2: Squared wave speed M / rho [mm^2/s^2] of the element's material.
        f: Internal forces, 3 per node (added to).
        energy: (n_cells,) stored penalty energy of each element (written) [N mm].

    Returns:
        The largest frequency bound omega^2 [1/s^2] of the active corners:
        ``2 wave2 / ratio^2`` times the sum over an element's active corners of the
        largest squared gradient ``|d r / d x_a|^2`` (0 where none is active).
    """
    omega2 = 0.0
    p = np.empty((8, 3))
    for c in range(nodes.shape[0]):
        for a in range(8):
            n = 3 * nodes[c, a]
            p[a, 0] = x[c, a, 0] + u[n]
            p[a, 1] = x[c, a, 1] + u[n + 1]
            p[a, 2] = x[c, a, 2] + u[n + 2]
        e = 0.0
        w2 = 0.0
        for k in range(8):
            i0, i1, i2 = int(edges[k, 0]), int(edges[k, 1]), int(edges[k, 2])
            s0, s1, s2 = edges[k, 3], edges[k, 4], edges[k, 5]
            # columns: the three edges from the corner, oriented along +xi_j
            a00, a10, a20 = s0 * (p[i0, 0] - p[k, 0]), s0 * (p[i0, 1] - p[k, 1]), \
                s0 * (p[i0, 2] - p[k, 2])
            a01, a11, a21 = s1 * (p[i1, 0] - p[k, 0]), s1 * (p[i1, 1] - p[k, 1]), \
                s1 * (p[i1, 2] - p[k, 2])
            a02, a12, a22 = s2 * (p[i2, 0] - p[k, 0]), s2 * (p[i2, 1] - p[k, 1]), \
                s2 * (p[i2, 2] - p[k, 2])
            c00 = a11 * a22 - a12 * a21
            c01 = a12 * a20 - a10 * a22
            c02 = a10 * a21 - a11 * a20
            r = (a00 * c00 + a01 * c01 + a02 * c02) / det0[c, k]
            if r >= ratio:
                continue
            c10 = a02 * a21 - a01 * a22
            c11 = a00 * a22 - a02 * a20
            c12 = a01 * a20 - a00 * a21
            c20 = a01 * a12 - a02 * a11
            c21 = a02 * a10 - a00 * a12
            c22 = a00 * a11 - a01 * a10
            deficit = (ratio - r) / ratio
            e += 0.5 * k_el[c] * deficit * deficit
            scale = -k_el[c] * deficit / (ratio * det0[c, k])  # dW/dr / det0
            # d det / d x_n(j) = s_j (column j of cof A)
            g = ((s0 * c00, s0 * c10, s0 * c20), (s1 * c01, s1 * c11, s1 * c21),
                 (s2 * c02, s2 * c12, s2 * c22))
            largest = 0.0
            for j, nb in ((0, i0), (1, i1), (2, i2)):
                n = 3 * nodes[c, nb]
                g0, g1, g2 = g[j]
                f[n] += scale * g0
                f[n + 1] += scale * g1
                f[n + 2] += scale * g2
                largest = max(largest, g0 * g0 + g1 * g1 + g2 * g2)
            h0 = g[0][0] + g[1][0] + g[2][0]
            h1 = g[0][1] + g[1][1] + g[2][1]
            h2 = g[0][2] + g[1][2] + g[2][2]
            n = 3 * nodes[c, k]
            f[n] -= scale * h0
            f[n + 1] -= scale * h1
            f[n + 2] -= scale * h2
            largest = max(largest, h0 * h0 + h1 * h1 + h2 * h2)
            w2 += largest / (det0[c, k] * det0[c, k])
        energy[c] = e
        omega2 = max(omega2, 2.0 * wave2 * w2 / (ratio * ratio))
    return omega2


def _corner_edges() -> np.ndarray:
    """Per corner of the P1 hexahedron: its neighbours along the 3 axes, then the signs."""
    pts = _P1.points
    out = np.empty((8, 6))
    for k in range(8):
        for j in range(3):
            other = pts[k].copy()
            other[j] = 1.0 - other[j]
            out[k, j] = int(np.flatnonzero(np.all(np.isclose(pts, other), axis=1))[0])
            out[k, 3 + j] = 1.0 if pts[k, j] < 0.5 else -1.0
    return out


class DistortionControl:
    """A penalty that keeps an element's corners from folding (explicit runs).

    Reduced and thickness-integrated hexahedra can fold at a corner (a punch's corner
    pressing one column of a crushable core into the layer below) while their one or
    two points keep a positive det F: their hourglass control resists the fold only
    elastically, and at a crushing element's floor. Abaqus/Explicit offers a distortion
    control for such solids; this one is a penalty on each corner's determinant ratio
    (:func:`corner_penalty`) below ``ratio``, with the stiffness ``M V / 8`` per element
    (``M`` the largest diagonal entry of the elastic stiffness, ``V`` the element's
    volume): at a fold the penalty pushes back with a stress of the order of
    ``M / (8 ratio)``. Its energy is an artificial strain energy, counted with the
    hourglass energy (Abaqus' ALLAE). See docs/theory.md, section 12.

    Args:
        nodes: (n_cells, 8) node (block) indices of the rank's owned cells.
        x: (n_cells, 8, 3) their reference coordinates.
        volume: (n_cells,) element volumes [mm^3].
        modulus: Elastic modulus M [MPa].
        wave2: Squared wave speed M / rho [mm^2/s^2].
        ratio: Corner determinant ratio below which the penalty acts, in (0, 1).
    """

    def __init__(self, nodes: np.ndarray, x: np.ndarray, volume: np.ndarray, modulus: float,
                 wave2: float, ratio: float):
        self.nodes = nodes
        self.x = np.ascontiguousarray(x)
        self.det0 = corner_dets(self.x)
        self.ratio = ratio
        self.k_el = modulus * volume / 8.0
        self.wave2 = wave2
        self.energy = np.zeros(nodes.shape[0])
        self._edges = _corner_edges()

    def add_forces(self, u: np.ndarray, f: np.ndarray) -> float:
        """Add the penalty forces at displacement ``u`` to ``f``; the frequency bound."""
        return corner_penalty(u, self.nodes, self.x, self._edges, self.det0, self.ratio,
                              self.k_el, self.wave2, f, self.energy)

    @property
    def stored(self) -> float:
        """Penalty energy of the rank's elements at the last evaluation [N mm]."""
        return float(self.energy.sum())
