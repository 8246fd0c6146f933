"""Reference geometry of the reduced hexahedra: thickness points and hourglass stiffness.

What :class:`~forming.bodies.hexforce.HexInternalForce` computes once, at the start of
an explicit run (or when the adaptive integration moves elements between its loops):
the thickness axis and the two Gauss points on it of the thickness-integrated element,
and the stiffness that full integration puts against each hourglass mode. See
docs/theory.md, section 12.
"""

from __future__ import annotations

import basix
import numpy as np

from forming.errors import InputError

_P1 = basix.create_element(basix.ElementFamily.P, basix.CellType.hexahedron, 1)


def shape_gradients(x: np.ndarray, points: np.ndarray,
                    element=_P1) -> tuple[np.ndarray, np.ndarray]:
    """Reference gradients of the shape functions and the Jacobians at ``points``.

    Isoparametric: the Jacobian is that of the element's own nodes.

    Args:
        x: (n_cells, n_nodes, 3) node coordinates.
        points: (n_q, 3) points of the reference cell [0, 1]^3.
        element: The basix element of the displacement (P1 by default).

    Returns:
        (gradients (n_cells, n_q, n_nodes, 3), det J (n_cells, n_q)).

    Raises:
        InputError: An element is inverted or degenerate in the reference mesh.
    """
    dxi = element.tabulate(1, points)[1:4, :, :, 0]  # (3, n_q, n): d N_a / d xi_k
    jac = np.einsum("cai,kqa->cqik", x, dxi)  # d x_i / d xi_k
    det = np.linalg.det(jac)
    if np.any(det <= 0.0):
        raise InputError("mesh", f"{int(np.sum(det <= 0))} hexahedron points with det J <= 0 "
                         "(inverted or degenerate elements)")
    inv = np.linalg.inv(jac)  # d xi_k / d x_j
    return np.einsum("kqa,cqkj->cqaj", dxi, inv), det


def point_geometry(body, element=_P1, cells: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Nodes, shape-function gradients and weights at a body's own quadrature points.

    On the rank's owned cells (:attr:`~forming.bodies.solid.SolidBody.point_cells`), in
    the order of the body's points, or on a subset of them.

    Args:
        body: The solid on hexahedra.
        element: The basix element of its displacement.
        cells: Positions in :attr:`point_cells` of the cells to take; None: all.

    Returns:
        (nodes (n_cells, n_nodes), gradients (n_cells, n_q, n_nodes, 3), quadrature
        weight times det J (n_cells, n_q), node coordinates (n_cells, n_nodes, 3)).

    Raises:
        InputError: The body's points are not basix's Gauss points of its degree.
    """
    owned = body.point_cells if cells is None else body.point_cells[cells]
    nodes = np.ascontiguousarray(body.V.dofmap.list[owned], dtype=np.int64)
    x = body.V.tabulate_dof_coordinates()[nodes]
    pts = body.QS.element.interpolation_points
    qpts, qw = basix.make_quadrature(basix.CellType.hexahedron, body.quadrature_degree)
    if not np.allclose(qpts, pts):  # the body's points, in its order
        raise InputError(f"body.{body.name}", "quadrature points differ from basix's")
    grads, det = shape_gradients(x, pts, element)
    return nodes, np.ascontiguousarray(grads), np.ascontiguousarray(det * qw), x


def thickness_axes(x: np.ndarray, element=_P1) -> np.ndarray:
    """The reference axis of each element nearest the global z (its thickness).

    Args:
        x: (n_cells, n_nodes, 3) node coordinates.
        element: The basix element of the nodes.

    Returns:
        (n_cells,) 0, 1 or 2: the axis whose tangent at the centre has the largest share
        of z.
    """
    dxi = element.tabulate(1, np.full((1, 3), 0.5))[1:4, 0, :, 0]  # (3, n)
    tangents = np.einsum("cai,ka->cki", x, dxi)
    share = np.abs(tangents[:, :, 2]) / np.linalg.norm(tangents, axis=2)
    return np.argmax(share, axis=1)


def thickness_points(x: np.ndarray, axis: np.ndarray, body_points: np.ndarray,
                     mean: np.ndarray, volume: np.ndarray,
                     element=_P1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gradients and weights at two Gauss points on each element's thickness axis.

    The gradients at the points ``g_q`` are shifted by the element's distortion,
    ``b_q = g_q - sum_q w_q g_q / V + b``, with ``b`` the exact mean gradient and the
    weights ``w_q`` the points' shares of the exact volume ``V`` (by det J): then
    ``sum_q w_q b_q = int grad N dV`` exactly, so a homogeneous deformation of a
    distorted mesh leaves the interior nodes in equilibrium (the patch test), and
    every linear field still has its exact gradient at both points. On a parallelepiped
    the shift is zero.

    Args:
        x: (n_cells, n_nodes, 3) node coordinates.
        axis: (n_cells,) each element's thickness axis (:func:`thickness_axes`).
        body_points: (n_q, 3) the body's own points on the reference cell [0, 1]^3.
        mean: (n_cells, n_nodes, 3) exact mean shape-function gradients.
        volume: (n_cells,) exact element volumes.
        element: The basix element of the nodes.

    Returns:
        (gradients (n_cells, 2, n_nodes, 3), weights (n_cells, 2), the index of the
        point on each body point's side of the mid-plane, ``2 c + side`` (n_cells, n_q)).
    """
    nc = x.shape[0]
    grads = np.empty((nc, 2, x.shape[1], 3))
    det = np.empty((nc, 2))
    for k in range(3):
        sel = axis == k
        if not sel.any():
            continue
        pts = np.full((2, 3), 0.5)
        pts[:, k] = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)
        grads[sel], det[sel] = shape_gradients(x[sel], pts, element)
    weights = volume[:, None] * det / det.sum(axis=1, keepdims=True)
    gbar = np.einsum("cq,cqaj->caj", weights, grads) / volume[:, None, None]
    grads += (mean - gbar)[:, None]
    side = body_points[:, axis].T > 0.5  # (n_cells, n_q): above the mid-plane
    return grads, weights, 2 * np.arange(nc)[:, None] + side.astype(np.int64)


def mode_stiffness(gamma: np.ndarray, grads: np.ndarray, weights: np.ndarray,
                   cel: np.ndarray) -> np.ndarray:
    """Stiffness of each hourglass mode of each element under full integration [N/mm].

    For mode ``alpha`` in displacement component ``i`` (nodal displacements
    ``u_a = gamma_alpha,a e_i``, whose mode amplitude is ``q = |gamma|^2``), the element's
    elastic 2 x 2 x 2 stiffness gives the energy ``u.K.u / 2``; the stiffness of the
    amplitude is ``k = u.K.u / |gamma|^4``. It takes the material's anisotropy and the
    element's shape into account: an in-plane mode of the honeycomb core is resisted by
    its in-plane moduli, not by its through-thickness one.

    Args:
        gamma: (n_cells, 4, 8) hourglass vectors.
        grads: (n_cells, n_q, 8, 3) shape-function gradients at the full points.
        weights: (n_cells, n_q) quadrature weights times det J.
        cel: (6, 6) Mandel elastic stiffness in the global frame.

    Returns:
        (n_cells, 4, 3) stiffness of every mode and component.
    """
    g = np.einsum("cma,cqaj->cmqj", gamma, grads)  # gradient of the mode's shape
    r = 1.0 / np.sqrt(2.0)
    out = np.zeros(gamma.shape[:2] + (3,))
    for i in range(3):
        eps = np.zeros(g.shape[:3] + (6,))  # Mandel sym(e_i (x) g)
        eps[..., i] = g[..., i]
        for m, (a, b) in enumerate(((1, 2), (0, 2), (0, 1)), start=3):
            if i == a:
                eps[..., m] = r * g[..., b]
            elif i == b:
                eps[..., m] = r * g[..., a]
        energy = np.einsum("cmqk,kl,cmql,cq->cm", eps, cel, eps, weights)
        out[..., i] = energy / np.sum(gamma * gamma, axis=2) ** 2
    return out
