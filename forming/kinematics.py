"""Finite-strain kinematics in UFL, and the Mandel notation the point kernels use.

Symmetric tensors travel between UFL and the quadrature-point kernels as Mandel
6-vectors ``[11, 22, 33, sqrt2*23, sqrt2*13, sqrt2*12]`` (docs/theory.md, section 2),
so that a double contraction is a dot product and a fourth-order tensor a 6 x 6 matrix.
"""

from __future__ import annotations

import math

import ufl

SQRT2 = math.sqrt(2.0)


def deformation_gradient(u):
    """UFL deformation gradient ``F = I + grad u`` of a 3D displacement."""
    return ufl.Identity(3) + ufl.grad(u)


def mandel_to_tensor(s):
    """UFL 3x3 symmetric tensor from a Mandel 6-vector."""
    return ufl.as_matrix(
        [
            [s[0], s[5] / SQRT2, s[4] / SQRT2],
            [s[5] / SQRT2, s[1], s[3] / SQRT2],
            [s[4] / SQRT2, s[3] / SQRT2, s[2]],
        ]
    )


def tensor_to_mandel(e):
    """Mandel 6-vector of a symmetric UFL tensor."""
    return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], SQRT2 * e[1, 2], SQRT2 * e[0, 2],
                          SQRT2 * e[0, 1]])


def mandel_contract(d, e):
    """UFL Mandel 6-vector ``D : e`` of a 6 x 6 tangent ``d`` and a 6-vector ``e``."""
    return ufl.as_vector([sum(d[i, j] * e[j] for j in range(6)) for i in range(6)])
