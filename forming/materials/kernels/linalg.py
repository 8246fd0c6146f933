"""Small dense solvers: 3x3 symmetric eigen-decomposition and 6x6 linear solves.

:func:`eig_sym3` diagonalises right Cauchy-Green tensors in closed form (numba's
``np.linalg`` needs a BLAS the stack does not ship); :func:`_lu_solve6x2` is the
Gaussian elimination of the return mapping's linear systems, with its factors kept for
:func:`_lu_resolve6` (the return's Newton slope needs a second solve). All work in place
on caller-provided arrays.
"""

from __future__ import annotations

import math

from .common import _inner


@_inner
def eig_sym3(a, n, m, q):
    """Eigen-decompositions of symmetric 3x3 matrices, in closed form.

    For each matrix ``A``: the deviator ``B = (A - tr(A)/3 I) / p`` scaled to
    ``tr(B^2) = 6`` has the eigenvalues ``2 cos(phi + 2 pi k / 3)``, ``cos(3 phi) =
    det(B) / 2`` (Smith 1961). Of them, the one farthest from the other two (at least 1.5
    away, whatever the matrix) has its eigenvector along the longest cross product of two
    rows of ``B - lambda I``; the other two eigenvectors come from one Jacobi rotation
    of ``B`` restricted to the plane normal to it, so that a pair of equal or nearly
    equal eigenvalues costs no accuracy. The eigenvalues are the Rayleigh quotients of
    the eigenvectors (residual and orthogonality near round-off, as cyclic Jacobi
    rotations, for a third of the cost). A multiple of the identity (``p = 0``) keeps
    the axes.

    Args:
        a: (>= n, 3, 3) symmetric matrices (not modified); the first ``n`` are used.
        n: Number of matrices.
        m: (>= n, 3, 3) output: the diagonalised matrices, eigenvalues on the diagonal.
        q: (>= n, 3, 3) output: the eigenvectors as columns.
    """
    for b in range(n):
        tr = (a[b, 0, 0] + a[b, 1, 1] + a[b, 2, 2]) / 3.0
        b00, b11, b22 = a[b, 0, 0] - tr, a[b, 1, 1] - tr, a[b, 2, 2] - tr
        b01 = 0.5 * (a[b, 0, 1] + a[b, 1, 0])
        b02 = 0.5 * (a[b, 0, 2] + a[b, 2, 0])
        b12 = 0.5 * (a[b, 1, 2] + a[b, 2, 1])
        p2 = (b00 * b00 + b11 * b11 + b22 * b22
              + 2.0 * (b01 * b01 + b02 * b02 + b12 * b12)) / 6.0
        for i in range(3):
            for j in range(3):
                m[b, i, j] = tr if i == j else 0.0
                q[b, i, j] = 1.0 if i == j else 0.0
        if not p2 > 0.0:  # (a multiple of the identity)
            continue
        p = math.sqrt(p2)
        s = 1.0 / p
        b00, b11, b22, b01, b02, b12 = b00 * s, b11 * s, b22 * s, b01 * s, b02 * s, b12 * s
        det = (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02)
               + b02 * (b01 * b12 - b11 * b02))
        phi = math.acos(min(max(0.5 * det, -1.0), 1.0)) / 3.0
        l1 = 2.0 * math.cos(phi)  # the largest
        l3 = 2.0 * math.cos(phi + 2.0943951023931957)  # the smallest
        lam = l1 if l1 + l3 >= 0.0 else l3  # l1 - l2 >= l2 - l3, as l2 = -l1 - l3
        # its eigenvector: the longest cross product of two rows of B - lam I
        r0x, r0y, r0z = b00 - lam, b01, b02
        r1x, r1y, r1z = b01, b11 - lam, b12
        r2x, r2y, r2z = b02, b12, b22 - lam
        vx, vy, vz = r0y * r1z - r0z * r1y, r0z * r1x - r0x * r1z, r0x * r1y - r0y * r1x
        nn = vx * vx + vy * vy + vz * vz
        cx, cy, cz = r0y * r2z - r0z * r2y, r0z * r2x - r0x * r2z, r0x * r2y - r0y * r2x
        nc = cx * cx + cy * cy + cz * cz
        if nc > nn:
            vx, vy, vz, nn = cx, cy, cz, nc
        cx, cy, cz = r1y * r2z - r1z * r2y, r1z * r2x - r1x * r2z, r1x * r2y - r1y * r2x
        nc = cx * cx + cy * cy + cz * cz
        if nc > nn:
            vx, vy, vz, nn = cx, cy, cz, nc
        s = 1.0 / math.sqrt(nn)
        vx, vy, vz = vx * s, vy * s, vz * s
        # an orthonormal pair (u, w) normal to v
        if abs(vx) > abs(vy):
            s = 1.0 / math.sqrt(vx * vx + vz * vz)
            ux, uy, uz = -vz * s, 0.0, vx * s
        else:
            s = 1.0 / math.sqrt(vy * vy + vz * vz)
            ux, uy, uz = 0.0, vz * s, -vy * s
        wx, wy, wz = vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux
        # B in the plane (u, w), and along v
        bux = b00 * ux + b01 * uy + b02 * uz
        buy = b01 * ux + b11 * uy + b12 * uz
        buz = b02 * ux + b12 * uy + b22 * uz
        bwx = b00 * wx + b01 * wy + b02 * wz
        bwy = b01 * wx + b11 * wy + b12 * wz
        bwz = b02 * wx + b12 * wy + b22 * wz
        huu = ux * bux + uy * buy + uz * buz
        hww = wx * bwx + wy * bwy + wz * bwz
        huw = ux * bwx + uy * bwy + uz * bwz
        hvv = (vx * (b00 * vx + b01 * vy + b02 * vz) + vy * (b01 * vx + b11 * vy + b12 * vz)
               + vz * (b02 * vx + b12 * vy + b22 * vz))
        c, sn = 1.0, 0.0
        if huw != 0.0:  # the Jacobi rotation that diagonalises the plane's 2 x 2 block
            theta = (hww - huu) / (2.0 * huw)
            t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
            c = 1.0 / math.sqrt(t * t + 1.0)
            sn = t * c
            huu, hww = huu - t * huw, hww + t * huw
        m[b, 0, 0] = tr + p * hvv
        m[b, 1, 1] = tr + p * huu
        m[b, 2, 2] = tr + p * hww
        q[b, 0, 0], q[b, 1, 0], q[b, 2, 0] = vx, vy, vz
        q[b, 0, 1], q[b, 1, 1], q[b, 2, 1] = c * ux - sn * wx, c * uy - sn * wy, c * uz - sn * wz
        q[b, 0, 2], q[b, 1, 2], q[b, 2, 2] = sn * ux + c * wx, sn * uy + c * wy, sn * uz + c * wz


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
