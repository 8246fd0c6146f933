"""Area transfer of finite sliding: a slave node's force spread over its tributary area.

Node-to-surface contact puts each slave node's force on the master at one point, the
node's closest point. On non-matching meshes that loads the master inconsistently (the
slave's nodal areas are a poor quadrature of the master's shape functions: 11% off on a
3-to-2 mesh), so even a uniform pressure is passed on unevenly and the contact patch test
fails. Here the force of node ``j`` reaches the master through the node's tributary
area instead: the slave facets around it, sampled by 4 x 4 Gauss points weighted by
the node's shape function ``N_j``, each point projected onto the master,

    f_a = A_j t_j sum_q phi_q N_a(xi_q),    phi_q = w_q N_j(q) / sum_r w_r N_j(r),

so that a uniform traction loads the master with ``integral N_a t dA`` up to the
quadrature of its shape functions' kinks (below 1% for 4 points). The slave side, the gap,
the pressure and the friction stay at the node (docs/theory.md, section 11).

Within a load step the points ride with their node: each is the node plus an offset taken
at the start of the step, from the slave surface as it then was.
"""

from __future__ import annotations

import numba
import numpy as np

from forming.contact.slidekernels import project_quad, shape, shape_tuple
from forming.contact.slidesurface import ring_step

_GAUSS = np.polynomial.legendre.leggauss(4)


def tributary_points(X0: np.ndarray, facets: np.ndarray, nodes: np.ndarray):
    """Gauss points of the facets around each node, weighted by its shape function.

    Args:
        X0: Surface node coordinates (n, 3).
        facets: Facets as rows of four node indices, counter-clockwise.
        nodes: The surface nodes that need points.

    Returns:
        ``(ptr, facet, st, phi)``: node ``k``'s points are ``ptr[k]:ptr[k+1]``, each on
        ``facet`` at facet coordinates ``st`` with weight ``phi`` (summing to 1 per node).
    """
    g, w = _GAUSS
    s, t = np.meshgrid(g, g, indexing="ij")
    st = np.column_stack([s.ravel(), t.ravel()])
    wq = np.outer(w, w).ravel()
    N = np.array([shape(a, b) for a, b in st])  # (16, 4)
    dN = np.array([[[-0.25 * (1 - b), -0.25 * (1 - a)], [0.25 * (1 - b), -0.25 * (1 + a)],
                    [0.25 * (1 + b), 0.25 * (1 + a)], [-0.25 * (1 + b), 0.25 * (1 - a)]]
                   for a, b in st])  # (16, 4, 2)
    by_node: dict[int, list[tuple[int, int]]] = {}
    for f, row in enumerate(facets):
        for a, v in enumerate(row):
            by_node.setdefault(int(v), []).append((f, a))
    ptr, pf, pst, phi = [0], [], [], []
    for v in nodes:
        weights = []
        for f, a in by_node.get(int(v), []):
            X = X0[facets[f]]
            for q in range(len(st)):
                J = dN[q].T @ X  # (2, 3)
                dA = np.linalg.norm(np.cross(J[0], J[1]))
                pf.append(f)
                pst.append(st[q])
                weights.append(wq[q] * dA * N[q, a])
        total = sum(weights)
        phi.extend(np.asarray(weights) / total if total > 0 else weights)
        ptr.append(len(pf))
    return (np.array(ptr, dtype=np.int64), np.array(pf, dtype=np.int64),
            np.array(pst, dtype=float).reshape(-1, 2), np.array(phi, dtype=float))


def bilinear_points(X: np.ndarray, st: np.ndarray) -> np.ndarray:
    """Points of bilinear facets: ``X`` (n, 4, 3) at coordinates ``st`` (n, 2) (n, 3)."""
    s, t = st[:, 0], st[:, 1]
    N = 0.25 * np.stack([(1 - s) * (1 - t), (1 + s) * (1 - t), (1 + s) * (1 + t),
                         (1 - s) * (1 + t)], axis=1)
    return np.einsum("na,naj->nj", N, X)


@numba.njit(cache=True)
def _weights_and_derivative(x, X, xi0, eta0, derivative, dN, N):
    """Clamped shape values at x's closest point on X, and (if asked) their derivative.

    The derivative with respect to x (3) and the facet's nodes (12) follows from the
    projection's condition ``F = [(x - p) . X,xi, (x - p) . X,eta] = 0`` (implicit
    function theorem: ``dxi/dz = -(dF/dxi)^-1 dF/dz``); a coordinate clamped at the
    facet's edge does not move. The values go into ``N`` (4,), the derivative into
    ``dN`` (4, 15); returns the unclamped coordinates. No temporary arrays (it runs for
    every point of every pair at every evaluation): the point, the tangents and ``dF``
    are scalars, summed in the order of :func:`~forming.contact.slidekernels.frame`.
    """
    xi, eta = project_quad(x, X, xi0, eta0)
    cx, ce = max(-1.0, min(1.0, xi)), max(-1.0, min(1.0, eta))
    Nt = shape_tuple(cx, ce)
    for a in range(4):
        N[a] = Nt[a]
    if not derivative:
        return xi, eta
    dN[:] = 0.0
    dxi_b = (-0.25 * (1 - ce), 0.25 * (1 - ce), 0.25 * (1 + ce), -0.25 * (1 + ce))
    deta_b = (-0.25 * (1 - cx), -0.25 * (1 + cx), 0.25 * (1 + cx), 0.25 * (1 - cx))
    cross = (0.25, -0.25, 0.25, -0.25)
    p0 = p1 = p2 = 0.0
    t10 = t11 = t12_ = 0.0
    t20 = t21 = t22 = 0.0
    c0 = c1 = c2 = 0.0
    for a in range(4):
        p0 += Nt[a] * X[a, 0]
        t10 += dxi_b[a] * X[a, 0]
        t20 += deta_b[a] * X[a, 0]
        c0 += cross[a] * X[a, 0]
        p1 += Nt[a] * X[a, 1]
        t11 += dxi_b[a] * X[a, 1]
        t21 += deta_b[a] * X[a, 1]
        c1 += cross[a] * X[a, 1]
        p2 += Nt[a] * X[a, 2]
        t12_ += dxi_b[a] * X[a, 2]
        t22 += deta_b[a] * X[a, 2]
        c2 += cross[a] * X[a, 2]
    r = (x[0] - p0, x[1] - p1, x[2] - p2)
    t1 = (t10, t11, t12_)
    t2 = (t20, t21, t22)
    a11 = t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]
    a22 = t2[0] * t2[0] + t2[1] * t2[1] + t2[2] * t2[2]
    a12 = (t1[0] * t2[0] + t1[1] * t2[1] + t1[2] * t2[2]) - (r[0] * c0 + r[1] * c1
                                                              + r[2] * c2)
    det = a11 * a22 - a12 * a12
    if det <= 0.0:
        return xi, eta
    free_xi = abs(xi) <= 1.0
    free_eta = abs(eta) <= 1.0
    for c in range(15):  # dF/dz column c: x, then node b's coordinates
        if c < 3:
            f0, f1 = t1[c], t2[c]
        else:
            b, j = (c - 3) // 3, (c - 3) % 3
            f0 = -Nt[b] * t1[j] + r[j] * dxi_b[b]
            f1 = -Nt[b] * t2[j] + r[j] * deta_b[b]
        dxi, deta = 0.0, 0.0
        if free_xi and free_eta:
            dxi = (a22 * f0 - a12 * f1) / det
            deta = (a11 * f1 - a12 * f0) / det
        elif free_xi:
            dxi = f0 / a11
        elif free_eta:
            deta = f1 / a22
        for a in range(4):
            dN[a, c] = dxi_b[a] * dxi + deta_b[a] * deta
    return xi, eta


@numba.njit(cache=True)
def spread(x, offsets, phi, which, Xk, xi, W, dW, derivative):
    """The master weights of one slave node and, optionally, their derivatives.

    Args:
        x: The slave node's position (3,).
        offsets: Its points' offsets from the node (P, 3).
        phi: Their weights (P,), summing to 1.
        which: Index of each point's facet among the node's K facets (P,).
        Xk: Those facets' nodes (K, 4, 3).
        xi: Each point's facet coordinates (P, 2): start of the projection, updated.
        W: Out (K, 4): ``sum_q phi_q N_a(xi_q)`` per facet node.
        dW: Out (K, 4, 15): its derivative with respect to the node's position (3) and
            the facet's nodes (12), in closed form.
        derivative: Whether to compute ``dW``.
    """
    W[:] = 0.0
    if derivative:
        dW[:] = 0.0
    dN = np.zeros((4, 15))
    N = np.empty(4)
    xq = np.empty(3)
    for q in range(offsets.shape[0]):
        k = which[q]
        for j in range(3):
            xq[j] = x[j] + offsets[q, j]
        a0, b0 = _weights_and_derivative(xq, Xk[k], xi[q, 0], xi[q, 1], derivative, dN, N)
        xi[q, 0], xi[q, 1] = a0, b0
        for a in range(4):
            W[k, a] += phi[q] * N[a]
            if derivative:
                for c in range(15):
                    dW[k, a, c] += phi[q] * dN[a, c]


@numba.njit(cache=True)
def follow(points, facets, xm, rings, facet, xi):
    """Walk each point to the facet of its closest point, from its last facet.

    Up to four one-ring walks per point (a point may cross more than one facet when
    the master mesh is finer than the slave's); the point stays on the best facet found.
    """
    X = np.empty((4, 3))
    for q in range(points.shape[0]):
        x = points[q]
        for a in range(4):
            for j in range(3):
                X[a, j] = xm[facets[facet[q], a], j]
        a, b = project_quad(x, X, xi[q, 0], xi[q, 1])
        if abs(a) <= 1.0 and abs(b) <= 1.0:  # still over its facet
            xi[q, 0], xi[q, 1] = a, b
            continue
        for _walk in range(4):
            f0 = facet[q]
            best, a, b = ring_step(x, f0, xi[q, 0], xi[q, 1], facets, xm, rings)
            facet[q], xi[q, 0], xi[q, 1] = best, a, b
            if best == f0:
                break


class AreaTransfer:
    """The tributary points of a rank's slave nodes and their master weights.

    Args:
        slave: The replicated slave surface (reference coordinates, facets, positions()).
        node_index: Each owned slave node's index in that surface.
        master_facets: The master surface's facets (rows of four node indices).
        master_rings: The master facets' one-rings, padded with -1.
    """

    def __init__(self, slave, node_index: np.ndarray, master_facets: np.ndarray,
                 master_rings: list[np.ndarray]):
        self.slave = slave
        self.ptr, self.pf, self.st, self.phi = tributary_points(slave.X0, slave.facets,
                                                                node_index)
        self.owner = np.repeat(np.arange(len(node_index)), np.diff(self.ptr))
        self.facets = master_facets
        self.rings = master_rings
        n = len(self.pf)
        self.offsets = np.zeros((n, 3))
        self.facet = np.zeros(n, dtype=np.int64)
        self.xi = np.zeros((n, 2))

    def repair(self, xs: np.ndarray, xm: np.ndarray, node_facet: np.ndarray) -> None:
        """A new load step: the points' offsets from the current slave surface.

        Args:
            xs: Current positions of the owned slave nodes.
            xm: Current positions of the master nodes.
            node_facet: Each owned slave node's master facet (the walks start there).
        """
        xsurf = self.slave.positions()
        points = bilinear_points(xsurf[self.slave.facets[self.pf]], self.st)
        self.offsets[:] = points - xs[self.owner]
        self.facet[:] = node_facet[self.owner]
        self.xi[:] = 0.0
        self.follow(xs, xm)

    def follow(self, xs: np.ndarray, xm: np.ndarray) -> None:
        """Move every point to the master facet it now lies over."""
        points = xs[self.owner] + self.offsets
        follow(points, self.facets, xm, self.rings, self.facet, self.xi)
