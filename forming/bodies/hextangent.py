"""Element stiffness matrices of a solid of trilinear hexahedra, without forms.

The implicit solver's Jacobian of a solid body is the linearisation of its internal
virtual work (:meth:`~forming.bodies.solid.SolidBody.jacobian`),

    K[(a, i), (b, k)] = sum_q w_q ( delta_ik g_a . S g_b + B_ai . D B_bk ),

with ``g_a`` the reference gradient of shape function ``a`` at point ``q``, ``S`` the
second Piola-Kirchhoff stress and ``D`` its tangent (Mandel 6-vector and 6 x 6 matrix,
what the point kernel returned), and ``B_ai = mandel(sym(F^T (e_i (x) g_a)))``. DOLFINx
assembles it from the form through generated code at about 20 us per hexahedron (8
points); :func:`element_tangents` computes the same matrices in one compiled loop and
sums them into the matrix's entries, which the solver hands to PETSc in one call
(:mod:`forming.solver.tangents`). Both are the same matrix to round-off
(``tests/test_hextangent.py``). See docs/theory.md, section 6.
"""

from __future__ import annotations

import numba
import numpy as np

from forming.bodies.hexgeometry import point_geometry
from forming.bodies.hexkernels import point_gradient
from forming.errors import InputError


@numba.njit(cache=True, fastmath=True)
def element_tangents(u, nodes, grads, weights, stress, tangent, keep, slots, out):
    """Element stiffness matrices of every cell summed into a matrix's entries.

    Prescribed rows and columns are left out (zero), as the forms' assembly does with
    Dirichlet conditions.

    Args:
        u: Nodal displacements, 3 per node (owned and ghost nodes of the rank).
        nodes: (n_cells, 8) local node of each element node.
        grads: (n_cells, n_q, 8, 3) reference gradients of the shape functions.
        weights: (n_cells, n_q) quadrature weight times det J.
        stress: (n_cells * n_q, 6) Mandel second Piola-Kirchhoff stress.
        tangent: (n_cells * n_q, 36) its Mandel tangent dS/dE, row-major.
        keep: (3 * n_nodes,) 1 for a free dof, 0 for a prescribed one (its row and
            column are left out, as the forms' assembly does with Dirichlet conditions).
        slots: (n_cells * 576,) the entry of ``out`` each element entry adds to (the
            24 x 24 matrices row-major, cell by cell).
        out: The matrix's entries (zeroed here).
    """
    nc, nq = weights.shape
    r = 0.7071067811865476
    b = np.empty((24, 6))
    db = np.empty((24, 6))
    k = np.empty((24, 24))
    dofs = np.empty(24, dtype=np.int64)
    out[:] = 0.0
    for c in range(nc):
        k[:] = 0.0
        for a in range(8):
            for i in range(3):
                dofs[3 * a + i] = 3 * nodes[c, a] + i
        for q in range(nq):
            w = weights[c, q]
            f00, f01, f02, f10, f11, f12, f20, f21, f22 = point_gradient(u, nodes, grads, c, q)
            p = c * nq + q
            s00, s11, s22 = stress[p, 0], stress[p, 1], stress[p, 2]
            s12, s02, s01 = r * stress[p, 3], r * stress[p, 4], r * stress[p, 5]
            for a in range(8):
                g0, g1, g2 = grads[c, q, a, 0], grads[c, q, a, 1], grads[c, q, a, 2]
                for i in range(3):
                    if i == 0:
                        h0, h1, h2 = f00, f01, f02
                    elif i == 1:
                        h0, h1, h2 = f10, f11, f12
                    else:
                        h0, h1, h2 = f20, f21, f22
                    row = 3 * a + i
                    b[row, 0] = h0 * g0
                    b[row, 1] = h1 * g1
                    b[row, 2] = h2 * g2
                    b[row, 3] = r * (h1 * g2 + h2 * g1)
                    b[row, 4] = r * (h0 * g2 + h2 * g0)
                    b[row, 5] = r * (h0 * g1 + h1 * g0)
            for row in range(24):
                for m in range(6):
                    s = 0.0
                    for j in range(6):
                        s += tangent[p, 6 * m + j] * b[row, j]
                    db[row, m] = w * s
            for ra in range(24):
                for cb in range(24):
                    s = 0.0
                    for m in range(6):
                        s += b[ra, m] * db[cb, m]
                    k[ra, cb] += s
            # geometric part: g_a . S g_b on the diagonal of the components
            for a in range(8):
                ga0, ga1, ga2 = grads[c, q, a, 0], grads[c, q, a, 1], grads[c, q, a, 2]
                t0 = s00 * ga0 + s01 * ga1 + s02 * ga2
                t1 = s01 * ga0 + s11 * ga1 + s12 * ga2
                t2 = s02 * ga0 + s12 * ga1 + s22 * ga2
                for bb in range(8):
                    geo = w * (t0 * grads[c, q, bb, 0] + t1 * grads[c, q, bb, 1]
                               + t2 * grads[c, q, bb, 2])
                    for i in range(3):
                        k[3 * a + i, 3 * bb + i] += geo
        base = 576 * c
        for ra in range(24):
            kr = keep[dofs[ra]]
            for cb in range(24):
                out[slots[base + 24 * ra + cb]] += k[ra, cb] * kr * keep[dofs[cb]]


class HexTangent:
    """The compiled element matrices of a solid body of trilinear hexahedra.

    On the rank's owned cells (:attr:`~forming.bodies.solid.SolidBody.point_cells`),
    at the body's own quadrature points, from the stress and tangent of its last
    point-kernel evaluation.

    Args:
        body: The solid (:class:`~forming.bodies.solid.SolidBody`), degree 1 on
            hexahedra with 2 x 2 x 2 points.

    Raises:
        InputError: Not such a body.
    """

    def __init__(self, body):
        if body.mesh.topology.cell_name() != "hexahedron" or body.spec.degree != 1:
            raise InputError(f"body.{body.name}", "compiled element matrices are for P1 "
                             "hexahedra")
        if body.quadrature_degree != 2:
            raise InputError(f"body.{body.name}", "compiled element matrices need the 2 x 2 "
                             "x 2 Gauss points (quadrature degree 2)")
        self.body = body
        self.nodes, self.grads, self.weights, _x = point_geometry(body)
        # the dofs of each element, in the order of the matrices' rows (node, component)
        self.dofs = (3 * self.nodes[:, :, None] + np.arange(3)).reshape(-1, 24)

    @property
    def n_cells(self) -> int:
        """Owned elements of the rank."""
        return self.nodes.shape[0]

    def matrices(self, keep: np.ndarray, slots: np.ndarray, out: np.ndarray) -> None:
        """The element matrices at the body's displacement and last point evaluation.

        Args:
            keep: 1 at every free dof of the body's space (owned and ghost), 0 where a
                value is prescribed.
            slots: (n_cells * 576,) where in ``out`` each entry of the element matrices
                (24 x 24 row-major in the order of :attr:`dofs`, cell by cell) is summed.
            out: The summed entries (overwritten).
        """
        body = self.body
        element_tangents(body.u.x.array, self.nodes, self.grads, self.weights,
                         body.point_stress, body.point_tangent, keep, slots, out)
