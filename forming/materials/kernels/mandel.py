"""Mandel 6-vector algebra: products and sums of 6-tuples, and rotations into Mandel form.

Symmetric tensors are Mandel 6-vectors ``[11, 22, 33, sqrt2*23, sqrt2*13, sqrt2*12]``
(:data:`_MI`, :data:`_MJ` map a Mandel index to its tensor indices); 6-vectors travel
as tuples, so nothing is allocated, and every sum runs in a fixed order (the results
are bit-for-bit those of the plain formulation). :func:`mandel_rotation` turns a 3x3
rotation into the 6x6 matrix acting on Mandel vectors.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .common import _inlined, _inner

SQRT2 = math.sqrt(2.0)
# Mandel index -> (a, b) tensor indices.
_MI = np.array([0, 1, 2, 1, 0, 0], dtype=np.int64)
_MJ = np.array([0, 1, 2, 2, 2, 1], dtype=np.int64)

_ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@_inner
def _mv6(a, x):
    """``a @ x`` for a 6x6 matrix (no BLAS; each sum in column order).

    Args:
        a: (6, 6) matrix.
        x: 6-vector (tuple or array).

    Returns:
        The product as a 6-tuple.
    """
    s0 = s1 = s2 = s3 = s4 = s5 = 0.0
    for j in range(6):
        xj = x[j]
        s0 += a[0, j] * xj
        s1 += a[1, j] * xj
        s2 += a[2, j] * xj
        s3 += a[3, j] * xj
        s4 += a[4, j] * xj
        s5 += a[5, j] * xj
    return s0, s1, s2, s3, s4, s5


@_inner
def _mtv6(a, x):
    """``a.T @ x`` for a 6x6 matrix (each sum in row order).

    Args:
        a: (6, 6) matrix.
        x: 6-vector (tuple or array).

    Returns:
        The product as a 6-tuple.
    """
    s0 = s1 = s2 = s3 = s4 = s5 = 0.0
    for i in range(6):
        xi = x[i]
        s0 += a[i, 0] * xi
        s1 += a[i, 1] * xi
        s2 += a[i, 2] * xi
        s3 += a[i, 3] * xi
        s4 += a[i, 4] * xi
        s5 += a[i, 5] * xi
    return s0, s1, s2, s3, s4, s5


@_inner
def _mul6(x, y):
    """Elementwise product of two 6-vectors.

    Args:
        x: 6-tuple.
        y: 6-tuple.

    Returns:
        ``x * y`` as a 6-tuple.
    """
    return (x[0] * y[0], x[1] * y[1], x[2] * y[2], x[3] * y[3], x[4] * y[4], x[5] * y[5])


@_inner
def _axpy6(x, a, y):
    """``x + a * y`` for two 6-vectors and a scalar.

    Args:
        x: 6-tuple.
        a: Scalar.
        y: 6-tuple.

    Returns:
        The result as a 6-tuple.
    """
    return (x[0] + a * y[0], x[1] + a * y[1], x[2] + a * y[2],
            x[3] + a * y[3], x[4] + a * y[4], x[5] + a * y[5])


@_inner
def _sub6(x, y):
    """Difference of two 6-vectors.

    Args:
        x: 6-tuple.
        y: 6-tuple.

    Returns:
        ``x - y`` as a 6-tuple.
    """
    return (x[0] - y[0], x[1] - y[1], x[2] - y[2], x[3] - y[3], x[4] - y[4], x[5] - y[5])


@_inner
def _dot6(x, y):
    """Dot product of two 6-vectors (sum in index order).

    Args:
        x: 6-tuple.
        y: 6-tuple.

    Returns:
        ``x . y``.
    """
    s = 0.0
    for i in range(6):
        s += x[i] * y[i]
    return s


@_inner
def _rtcr(r, c, cr, out, ncol):
    """Write the first ``ncol`` columns of ``r.T @ c @ r`` into ``out`` (6x6 matrices).

    Args:
        r: (6, 6) rotation.
        c: (6, 6) matrix to rotate.
        cr: (6, 6) scratch; its first ``ncol`` columns receive ``c @ r``.
        out: (6, 6) output; columns ``ncol`` and beyond are left as they are.
        ncol: Number of columns wanted (the elastic update needs 3).
    """
    for k in range(6):
        for j in range(ncol):
            s = 0.0
            for m in range(6):
                s += c[k, m] * r[m, j]
            cr[k, j] = s
    for i in range(6):
        for j in range(ncol):
            s = 0.0
            for k in range(6):
                s += r[k, i] * cr[k, j]
            out[i, j] = s


@_inlined
def _is_isotropic(c):
    """Whether a Mandel stiffness is isotropic: the same in every frame (to 1e-14).

    Isotropic: ``c[:3, :3] = lambda + 2 mu I``, ``c[3:, 3:] = 2 mu I``, nothing else.
    """
    tol = 1e-14 * abs(c[0, 0])
    d, o = c[0, 0], c[0, 1]
    g = d - o
    for i in range(6):
        for j in range(6):
            if i < 3 and j < 3:
                want = d if i == j else o
            else:
                want = g if i == j else 0.0
            if abs(c[i, j] - want) > tol:
                return False
    return True


@_inlined
def _stiffness_in_frame(r, c, cr, out, ncol):
    """The first ``ncol`` columns of ``r.T @ c @ r`` (:func:`_rtcr`).

    An isotropic ``c``, the same in every frame, is copied instead of rotated (two 6x6
    products saved).
    """
    if _is_isotropic(c):
        for i in range(6):
            for j in range(ncol):
                out[i, j] = c[i, j]
        return
    _rtcr(r, c, cr, out, ncol)


@_inner
def _mandel_rotation_into(q, r):
    """Write the Mandel rotation of ``q`` into ``r`` (see :func:`mandel_rotation`).

    Args:
        q: (3, 3) orthogonal matrix.
        r: (6, 6) output.
    """
    for j in range(6):
        a = _MI[j]
        b = _MJ[j]
        for i in range(6):
            k = _MI[i]
            l = _MJ[i]  # noqa: E741
            # (q B q^T)_kl with B = (e_a e_b^T + e_b e_a^T) / sqrt2 (a != b) or e_a e_a^T
            if a == b:
                v = q[k, a] * q[l, a]
            else:
                v = (1.0 / SQRT2) * (q[k, a] * q[l, b] + q[k, b] * q[l, a])
            r[i, j] = v if k == l else SQRT2 * v


@numba.njit(cache=True)
def mandel_rotation(q):
    """6x6 matrix R with ``mandel(q A q^T) = R @ mandel(A)`` (orthogonal).

    Args:
        q: (3, 3) orthogonal matrix.

    Returns:
        The (6, 6) Mandel rotation.
    """
    r = np.empty((6, 6))
    _mandel_rotation_into(q, r)
    return r
