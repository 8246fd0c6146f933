"""Small dense solvers: batched 3x3 symmetric eigen-decomposition and 6x6 linear solves.

:func:`eig_sym3` diagonalises the right Cauchy-Green tensors of all the stress
updates of a point at once by cyclic Jacobi rotations (numba's ``np.linalg`` needs
a BLAS the stack does not ship); :func:`_lu_solve6x2` is the Gaussian elimination of
the return mapping's linear systems, with its factors kept for :func:`_lu_resolve6`
(the return's Newton slope needs a second solve). All work in place on
caller-provided arrays.
"""

from __future__ import annotations

import math

from .common import _inner


@_inner
def eig_sym3(a, n, m, q, active, turn, cs):
    """Eigen-decompositions of symmetric 3x3 matrices by cyclic Jacobi rotations.

    Robust for repeated eigenvalues (the undeformed state has three). The matrices
    are independent and rotated together: for each pivot, first the rotation angles
    of all of them (divisions and square roots, whose latencies then overlap), then
    the rotations. Every matrix sees exactly the operations of a decomposition on
    its own.

    Args:
        a: (>= n, 3, 3) symmetric matrices (not modified); the first ``n`` are used.
        n: Number of matrices.
        m: (>= n, 3, 3) output: the diagonalised matrices, eigenvalues on the diagonal.
        q: (>= n, 3, 3) output: the eigenvectors as columns.
        active: (>= n,) scratch: matrices not converged.
        turn: (>= n,) scratch: matrices to rotate at the current pivot.
        cs: (>= n, 2) scratch: cosine and sine of their rotations.
    """
    for b in range(n):
        for i in range(3):
            for j in range(3):
                m[b, i, j] = a[b, i, j]
                q[b, i, j] = 1.0 if i == j else 0.0
        active[b] = True
    for _sweep in range(50):
        rotating = False
        for b in range(n):
            if active[b]:
                off = m[b, 0, 1] ** 2 + m[b, 0, 2] ** 2 + m[b, 1, 2] ** 2
                scale = m[b, 0, 0] ** 2 + m[b, 1, 1] ** 2 + m[b, 2, 2] ** 2
                active[b] = not (off <= 1e-30 * scale or off == 0.0)
                rotating = rotating or active[b]
        if not rotating:
            break
        for p in range(2):
            for r in range(p + 1, 3):
                for b in range(n):
                    apr = m[b, p, r]
                    turn[b] = active[b] and apr != 0.0
                    # (the angle of a matrix not turning is computed, harmlessly, and unused)
                    theta = (m[b, r, r] - m[b, p, p]) / (2.0 * apr if turn[b] else 1.0)
                    t = ((1.0 if theta >= 0.0 else -1.0)
                         / (abs(theta) + math.sqrt(theta * theta + 1.0)))
                    c = 1.0 / math.sqrt(t * t + 1.0)
                    cs[b, 0] = c
                    cs[b, 1] = t * c
                for b in range(n):
                    if not turn[b]:
                        continue
                    c = cs[b, 0]
                    s = cs[b, 1]
                    for k in range(3):
                        mkp = m[b, k, p]
                        mkr = m[b, k, r]
                        m[b, k, p] = c * mkp - s * mkr
                        m[b, k, r] = s * mkp + c * mkr
                    for k in range(3):
                        mpk = m[b, p, k]
                        mrk = m[b, r, k]
                        m[b, p, k] = c * mpk - s * mrk
                        m[b, r, k] = s * mpk + c * mrk
                    for k in range(3):
                        qkp = q[b, k, p]
                        qkr = q[b, k, r]
                        q[b, k, p] = c * qkp - s * qkr
                        q[b, k, r] = s * qkp + c * qkr


@_inner
def _back_substitute6(m, c):
    """Back substitution with the upper factor in ``m[:, :6]`` for column ``c``, in place."""
    for k in range(5, -1, -1):
        s = m[k, c]
        for j in range(k + 1, 6):
            s -= m[k, j] * m[j, c]
        m[k, c] = s / m[k, k]


@_inner
def _lu_solve6x2(m):
    """LU factorisation with partial pivoting of a 6x6 system with two right-hand sides.

    Args:
        m: (6, >= 9): ``[A | b1 | b2 | .]``, overwritten: the unit lower factor's
            multipliers below the diagonal, the upper factor on and above it (of the
            rows permuted), columns 6 and 7 the solutions, column 8 the row each
            pivot came from.

    Returns:
        False if a zero pivot was met.
    """
    for k in range(6):
        p = k
        best = abs(m[k, k])
        for i in range(k + 1, 6):
            if abs(m[i, k]) > best:
                best = abs(m[i, k])
                p = i
        if best == 0.0:
            return False
        if p != k:
            for j in range(8):
                tmp = m[k, j]
                m[k, j] = m[p, j]
                m[p, j] = tmp
        m[k, 8] = p
        for i in range(k + 1, 6):
            f = m[i, k] / m[k, k]
            m[i, k] = f
            if f != 0.0:
                for j in range(k + 1, 8):
                    m[i, j] -= f * m[k, j]
    _back_substitute6(m, 6)
    _back_substitute6(m, 7)
    return True


@_inner
def _lu_resolve6(m):
    """Solve ``A x = b`` with the factors :func:`_lu_solve6x2` left in ``m``.

    Args:
        m: (6, 10) the factored system, ``b`` in column 9, which receives ``x``.
    """
    for k in range(6):
        p = int(m[k, 8])
        if p != k:
            tmp = m[k, 9]
            m[k, 9] = m[p, 9]
            m[p, 9] = tmp
        for i in range(k + 1, 6):
            m[i, 9] -= m[i, k] * m[k, 9]
    _back_substitute6(m, 9)
