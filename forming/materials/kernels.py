"""Quadrature-point kernels (numba) for the Lagrangian generalised-strain materials.

Conventions:
    * Symmetric tensors are Mandel 6-vectors ``[11, 22, 33, sqrt2*23, sqrt2*13, sqrt2*12]``,
      so that double contractions are plain dot products and fourth-order tensors are
      6x6 matrices.
    * Kinematics: the right Cauchy-Green tensor ``C = F^T F`` with eigenvalues ``c_a``
      and eigenvectors ``N_a``. The Lagrangian strain of the Seth-Hill family is
      ``E = sum_a f(c_a) N_a (x) N_a`` with ``f(c) = ln(c)/2`` (Hencky, measure 0) or
      ``f(c) = sqrt(c) - 1`` (Biot, measure 1), or Biot for ``c >= 1`` and Hencky
      below (measure 2, continuously differentiable at ``c = 1``).
    * Stress ``T`` is work-conjugate to ``E``; the second Piola-Kirchhoff stress is
      ``S = 2 T : dE/dC``; in the eigenbasis of ``C``, ``S_ab = 2 theta_ab T_ab`` with
      ``theta_ab`` the divided difference of ``f`` (Daleckii-Krein).
    * Plasticity is additive in ``E`` (``E = Ee + Ep``); the yield function is written
      in the rotated Cauchy stress ``U S U / J``, which in the eigenbasis of ``C`` is
      ``sigma_ab = kappa_ab T_ab`` with ``kappa_ab = 2 lambda_a lambda_b theta_ab / J``.

The tangent ``D = dS/dE_GL`` is computed by central perturbation of the whole
stress update (Miehe 1996, CMAME 134), which gives the algorithmic (consistent)
tangent up to an O(h^2) truncation error (about 1e-10 relative; larger only where
+/-h straddles the yield surface).

Performance (the tangent takes 13 stress updates per point):
    * Results are bit-for-bit those of the plain formulation: every floating-point
      value that reaches an output is computed by the same operations in the same
      order. This matters because the difference quotient divides round-off in
      ``S`` by ``h``, and the stopping test of the return mapping turns any
      round-off change into another last iterate: a reordered sum alone moves ``D``
      by about 1e-9.
    * Nothing is allocated per point: a kernel call allocates its scratch arrays
      once, and 6-vectors travel as tuples.
    * The inner functions are compiled without the numba runtime (``_inner``), so
      the arrays they pass around are not reference-counted.
    * The 13 eigen-decompositions of a point run as one batch: the Jacobi angles
      of all matrices (divisions and square roots) are computed before the
      rotations, so their latencies overlap.
    * The geometric bracketing of the return mapping only needs the sign of the
      yield value at most of its trial points; a rigorous lower bound proves it
      positive where it is far from zero, which skips the linear solve there
      (:func:`_phi_surely_positive`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

SQRT2 = math.sqrt(2.0)
# Mandel index -> (a, b) tensor indices.
_MI = np.array([0, 1, 2, 1, 0, 0], dtype=np.int64)
_MJ = np.array([0, 1, 2, 2, 2, 1], dtype=np.int64)

STATUS_OK = 0
STATUS_INVERTED = 1  # C not positive definite (det F <= 0 is checked by the caller)
STATUS_RETURN_MAP = 2  # local Newton of the return mapping did not converge

MEASURE_HENCKY = 0
MEASURE_BIOT = 1
MEASURE_BIOT_HENCKY = 2  # Biot for principal stretches > 1, Hencky below (C1 at 1)

_NUPD = 13  # stress updates per point with the tangent: C and C +/- h in 6 directions
_ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

# The inner functions allocate nothing, so they are compiled without the numba
# runtime (NRT; ``_nrt`` is numba's switch for it): the arrays they pass around are
# then not reference-counted. With the runtime, every call that passes arrays
# increments and decrements their counts with atomic operations (numba issue
# #2345), which cost more than the arithmetic of these kernels. Allocating in such a
# function is a compile error ("NRT required but not enabled").
_inner = numba.njit(cache=True, _nrt=False)


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


@_inner
def strain_f(c, measure):
    """Principal generalised strain for a principal value ``c`` of C.

    Args:
        c: Eigenvalue of C (positive).
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).

    Returns:
        ``f(c)``.
    """
    if measure == MEASURE_HENCKY or (measure == MEASURE_BIOT_HENCKY and c < 1.0):
        return 0.5 * math.log(c)
    return math.sqrt(c) - 1.0


@_inner
def _theta_hencky(ca, cb):
    """Divided difference of ``f(c) = ln(c)/2``, by a series for close arguments.

    Args:
        ca: First eigenvalue of C.
        cb: Second eigenvalue of C.

    Returns:
        ``(f(ca) - f(cb)) / (ca - cb)``.
    """
    x = ca / cb - 1.0
    if abs(x) < 1e-5:
        return (1.0 - 0.5 * x + x * x / 3.0 - 0.25 * x * x * x) / (2.0 * cb)
    return math.log1p(x) / x / (2.0 * cb)


@_inner
def strain_theta(ca, cb, measure):
    """Divided difference ``(f(ca) - f(cb)) / (ca - cb)``, ``f'(ca)`` in the limit.

    Args:
        ca: First eigenvalue of C.
        cb: Second eigenvalue of C.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).

    Returns:
        ``theta_ab``.
    """
    if measure == MEASURE_BIOT:
        return 1.0 / (math.sqrt(ca) + math.sqrt(cb))
    if measure == MEASURE_HENCKY:
        return _theta_hencky(ca, cb)
    if ca >= 1.0 and cb >= 1.0:
        return 1.0 / (math.sqrt(ca) + math.sqrt(cb))
    if ca < 1.0 and cb < 1.0:
        return _theta_hencky(ca, cb)
    if abs(ca - cb) < 1e-7:
        return 0.5  # f'(1) of both branches
    return (strain_f(ca, measure) - strain_f(cb, measure)) / (ca - cb)


@_inner
def _kappa(ca, cb, theta, jac):
    """Sigma-scaling ``kappa_ab = 2 sqrt(ca cb) theta_ab / J`` of one Mandel component.

    Args:
        ca: First eigenvalue of C of the component.
        cb: Second eigenvalue of C of the component.
        theta: ``theta_ab``.
        jac: ``J = sqrt(det C)``.

    Returns:
        ``kappa_ab``.
    """
    return 2.0 * math.sqrt(ca * cb) * theta / jac


@_inner
def _kinematics(c, measure, with_kappa):
    """Eigen-frame kinematics of C: strain, S- and sigma-scalings.

    Args:
        c: The eigenvalues of C (3-tuple).
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        with_kappa: Compute the sigma-scalings (else returned as zeros).

    Returns:
        (C positive definite, strain, S-scalings ``2 theta_ab``, sigma-scalings
        ``kappa_ab``), the last three as Mandel 6-tuples in the eigenframe (zero if
        C is not positive definite).
    """
    c0, c1, c2 = c
    if not (c0 > 0.0 and c1 > 0.0 and c2 > 0.0):
        return False, _ZERO6, _ZERO6, _ZERO6
    e_eig = (strain_f(c0, measure), strain_f(c1, measure), strain_f(c2, measure), 0.0, 0.0, 0.0)
    # Mandel component (a, b): (0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)
    th0 = strain_theta(c0, c0, measure)
    th1 = strain_theta(c1, c1, measure)
    th2 = strain_theta(c2, c2, measure)
    th3 = strain_theta(c1, c2, measure)
    th4 = strain_theta(c0, c2, measure)
    th5 = strain_theta(c0, c1, measure)
    s_fac = (2.0 * th0, 2.0 * th1, 2.0 * th2, 2.0 * th3, 2.0 * th4, 2.0 * th5)
    if not with_kappa:
        return True, e_eig, s_fac, _ZERO6
    jac = math.sqrt(c0 * c1 * c2)
    k_fac = (_kappa(c0, c0, th0, jac), _kappa(c1, c1, th1, jac), _kappa(c2, c2, th2, jac),
             _kappa(c1, c2, th3, jac), _kappa(c0, c2, th4, jac), _kappa(c0, c1, th5, jac))
    return True, e_eig, s_fac, k_fac


@_inner
def _solve6(m):
    """Solve a 6x6 system in place by Gaussian elimination with partial pivoting.

    Entries below the diagonal are left stale once eliminated (never read again).

    Args:
        m: (6, 7) augmented matrix ``[A | b]``, overwritten by its elimination;
            column 6 receives the solution (the partly eliminated ``b`` if ``A`` is
            singular).

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
            for j in range(k, 7):
                tmp = m[k, j]
                m[k, j] = m[p, j]
                m[p, j] = tmp
        for i in range(k + 1, 6):
            f = m[i, k] / m[k, k]
            if f != 0.0:
                for j in range(k + 1, 7):
                    m[i, j] -= f * m[k, j]
    for k in range(5, -1, -1):
        s = m[k, 6]
        for j in range(k + 1, 6):
            s -= m[k, j] * m[j, 6]
        m[k, 6] = s / m[k, k]
    return True


@_inner
def hermite_eval(x, xs, ys, ds):
    """Piecewise cubic Hermite value and slope; constant below ``xs[0]``, linear above.

    Args:
        x: Abscissa.
        xs: Table abscissae (increasing).
        ys: Table values.
        ds: Table slopes.

    Returns:
        (value, slope) at ``x``.
    """
    n = xs.shape[0]
    if x <= xs[0]:
        return ys[0], 0.0
    if x >= xs[n - 1]:
        return ys[n - 1] + ds[n - 1] * (x - xs[n - 1]), ds[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    h = xs[hi] - xs[lo]
    t = (x - xs[lo]) / h
    t2 = t * t
    t3 = t2 * t
    h00 = 2 * t3 - 3 * t2 + 1
    h10 = t3 - 2 * t2 + t
    h01 = -2 * t3 + 3 * t2
    h11 = t3 - t2
    y = h00 * ys[lo] + h10 * h * ds[lo] + h01 * ys[hi] + h11 * h * ds[hi]
    dh00 = (6 * t2 - 6 * t) / h
    dh10 = 3 * t2 - 4 * t + 1
    dh01 = (-6 * t2 + 6 * t) / h
    dh11 = 3 * t2 - 2 * t
    dy = dh00 * ys[lo] + dh10 * ds[lo] + dh01 * ys[hi] + dh11 * ds[hi]
    return y, dy


@_inner
def _hermite_slope_bound(xs, ys, ds):
    """Bound on ``|dy/dx|`` of :func:`hermite_eval` over the whole real line.

    On each interval the slope is a quadratic in the local coordinate, so its
    largest magnitude is at an end or at the vertex. Intervals of zero width are
    never evaluated and are skipped.

    Args:
        xs: Table abscissae (increasing).
        ys: Table values.
        ds: Table slopes.

    Returns:
        The Lipschitz constant of the curve.
    """
    n = xs.shape[0]
    bound = abs(ds[n - 1])
    for i in range(n - 1):
        h = xs[i + 1] - xs[i]
        if not h > 0.0:
            continue
        # slope = a t^2 + b t + c for t in [0, 1]
        a = (6.0 * (ys[i] - ys[i + 1]) + 3.0 * h * (ds[i] + ds[i + 1])) / h
        b = (6.0 * (ys[i + 1] - ys[i]) - h * (4.0 * ds[i] + 2.0 * ds[i + 1])) / h
        c = ds[i]
        bound = max(bound, abs(c), abs(a + b + c))
        if a != 0.0 and 0.0 < -b / (2.0 * a) < 1.0:
            bound = max(bound, abs(c - b * b / (4.0 * a)))
    return bound


@_inner
def _foam_yield(sig, pc, pt, alpha):
    """Crushable-foam yield value for a rotated Cauchy stress, p > 0 in compression.

    Args:
        sig: Rotated Cauchy stress (Mandel 6-tuple).
        pc: Hydrostatic compression strength.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.

    Returns:
        The yield value (positive outside the surface).
    """
    tr = sig[0] + sig[1] + sig[2]
    p = -tr / 3.0
    q2 = 0.0
    for i in range(6):
        d = sig[i] - (tr / 3.0 if i < 3 else 0.0)
        q2 += d * d
    q2 *= 1.5
    p0 = 0.5 * (pc - pt)
    return math.sqrt(q2 + alpha * alpha * (p - p0) ** 2) - 0.5 * alpha * (pc + pt)


@_inner
def _rm_phi(mu, c_eig, k_fac, t_tr, lu, evp_n, xs, ys, ds, pt, alpha, visc):
    """Yield value after a return of size ``mu``.

    The flow is radial in the rotated Cauchy stress (``dg m = mu sigma``), so for a
    given ``mu`` the update ``T = T_tr - mu C K T`` is linear:
    ``T = (I + mu C K)^-1 T_tr`` with ``K = diag(kappa)``. With viscous regularisation
    (``visc = eta / dt > 0``, Duvaut-Lions/Perzyna overstress) the value is
    ``f - visc * dgamma`` with ``dgamma = 2/3 mu g``, ``g = sqrt(3/2 sigma : sigma)``.

    Args:
        mu: Return size.
        c_eig: (6, 6) elastic stiffness in the eigenframe.
        k_fac: Sigma-scalings ``kappa`` (6-tuple).
        t_tr: Trial stress T (6-tuple).
        lu: (6, 7) scratch for the linear solve.
        evp_n: Converged volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.
        visc: ``eta / dt`` (no regularisation unless positive).

    Returns:
        (yield value, stress T, rotated Cauchy stress), the last two as 6-tuples.
    """
    for i in range(6):
        for j in range(6):
            lu[i, j] = mu * c_eig[i, j] * k_fac[j]
        lu[i, i] += 1.0
        lu[i, 6] = t_tr[i]
    _solve6(lu)
    t = (lu[0, 6], lu[1, 6], lu[2, 6], lu[3, 6], lu[4, 6], lu[5, 6])
    sig = _mul6(k_fac, t)
    evp = evp_n - mu * (sig[0] + sig[1] + sig[2])
    pc, _h = hermite_eval(evp, xs, ys, ds)
    f = _foam_yield(sig, pc, pt, alpha)
    if visc > 0.0:
        f -= visc * (2.0 / 3.0) * mu * math.sqrt(1.5 * _dot6(sig, sig))
    return f, t, sig


@_inner
def _phi_bound_data(f_tr, c_eig, k_fac, t_tr, scale, evp_n, pc_slope, alpha, visc):
    """Constants of the lower bound of :func:`_phi_surely_positive` for one update.

    Args:
        f_tr: Trial yield value.
        c_eig: (6, 6) elastic stiffness in the eigenframe.
        k_fac: Sigma-scalings ``kappa`` (6-tuple).
        t_tr: Trial stress T (6-tuple).
        scale: ``pc + pt`` at the converged state.
        evp_n: Converged volumetric plastic strain.
        pc_slope: Lipschitz constant of the hardening curve.
        alpha: Shape factor of the yield ellipse.
        visc: ``eta / dt`` (no regularisation unless positive).

    Returns:
        (f_tr, ``||C K||_inf``, ``||K||_2 ||C K T_tr||_inf``, ``|tr sigma_tr|``,
        ``||sigma_tr||_2``, ``L_sigma``, ``alpha L_pc``, viscous factor, margin); the
        bound is disabled (infinite norm) if the trial state is not finite.
    """
    norm_m = 0.0
    norm_mt = 0.0
    for i in range(6):
        row = 0.0
        mt = 0.0
        for j in range(6):
            row += abs(c_eig[i, j] * k_fac[j])
            mt += c_eig[i, j] * k_fac[j] * t_tr[j]
        norm_m = max(norm_m, row)
        norm_mt = max(norm_mt, abs(mt))
    norm_k = 0.0
    norm_sig = 0.0
    for i in range(6):
        norm_k += k_fac[i] * k_fac[i]
        norm_sig += (k_fac[i] * t_tr[i]) ** 2
    norm_sig = math.sqrt(norm_sig)
    tr_sig = abs(k_fac[0] * t_tr[0] + k_fac[1] * t_tr[1] + k_fac[2] * t_tr[2])
    l_sig = math.sqrt(max(1.5, alpha * alpha / 3.0))
    visc_factor = visc * (2.0 / 3.0) * math.sqrt(1.5) if visc > 0.0 else 0.0
    margin = 1e-8 * (scale + alpha * (scale + pc_slope * (abs(evp_n) + 1.0)) + l_sig * norm_sig)
    if not (math.isfinite(f_tr) and math.isfinite(norm_mt) and math.isfinite(margin)
            and math.isfinite(visc_factor)):
        norm_m = math.inf
    return (f_tr, norm_m, math.sqrt(norm_k) * norm_mt, tr_sig, norm_sig, l_sig,
            alpha * pc_slope, visc_factor, margin)


@_inner
def _phi_surely_positive(mu, bound):
    """Whether the yield value after a return of size ``mu`` is certainly positive.

    With ``M = C K`` and ``eps = mu ||M||_inf <= 1/2``, the solution of
    ``(I + mu M) T = T_tr`` satisfies ``||T - T_tr||_inf <= mu ||M T_tr||_inf /
    (1 - eps)``, hence ``||sigma - sigma_tr||_2 <= ||K||_2`` times that (``dsig``).
    The yield function is Lipschitz in sigma with ``L_sigma = sqrt(max(3/2,
    alpha^2/3))`` and in ``pc`` with ``alpha``; ``pc`` moves by at most
    ``L_pc mu |tr sigma| <= L_pc mu (|tr sigma_tr| + sqrt3 dsig)``; the viscous
    term is at most ``visc 2/3 sqrt(3/2) mu (||sigma_tr||_2 + dsig)``. So ``phi(mu)``
    is at least ``f_tr`` minus these three.

    The margin (1e-8 of the magnitudes involved) exceeds by far the round-off of
    the floating-point ``phi``, so a positive answer means that
    :func:`_rm_phi` would return a positive value.

    Args:
        mu: Return size.
        bound: Constants from :func:`_phi_bound_data`.

    Returns:
        True if ``phi(mu)`` is positive for sure (False says nothing).
    """
    f_tr, norm_m, k_mt, tr_sig, norm_sig, l_sig, alpha_lpc, visc_factor, margin = bound
    eps = mu * norm_m
    if not eps <= 0.5:
        return False
    dsig = mu * k_mt / (1.0 - eps)
    lower = (f_tr - l_sig * dsig - alpha_lpc * mu * (tr_sig + math.sqrt(3.0) * dsig)
             - (1.0 + 1e-8) * visc_factor * mu * (norm_sig + dsig))
    return lower > margin


@_inner
def _return_mapping(f_tr, tol, bound, c_eig, k_fac, t_tr, lu, evp_n, xs, ys, ds, pt, alpha,
                    visc):
    """Smallest root ``mu > 0`` of ``phi(mu) = f(sigma(mu), pc(evp(mu)))``.

    Bracketed by geometric search from ``phi(0) = f_tr > 0`` (at most 80 doublings
    of the first trial), then Illinois regula falsi (at most 200 steps). The search
    only needs the sign of ``phi`` until it turns, so trials that
    :func:`_phi_surely_positive` certifies skip the solve; the last positive trial
    is evaluated when the bracket closes, as it is the Illinois start.

    Args:
        f_tr: Trial yield value (positive).
        tol: Tolerance on ``|phi|``.
        bound: Constants from :func:`_phi_bound_data`.
        c_eig: (6, 6) elastic stiffness in the eigenframe.
        k_fac: Sigma-scalings ``kappa`` (6-tuple).
        t_tr: Trial stress T (6-tuple).
        lu: (6, 7) scratch for the linear solves.
        evp_n: Converged volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.
        visc: ``eta / dt`` (no regularisation unless positive).

    Returns:
        (converged, mu, stress T, rotated Cauchy stress) at the root, the last two
        as 6-tuples.
    """
    cmax = 0.0
    for i in range(6):
        cmax = max(cmax, c_eig[i, i] * k_fac[i])
    mu_lo, f_lo = 0.0, f_tr
    mu_hi = 1e-4 / cmax
    f_hi = f_tr
    # whether f_lo and f_hi are the values at mu_lo and mu_hi (not just known positive)
    lo_known = hi_known = True
    t = sig = _ZERO6
    for doublings in range(81):
        if doublings > 0:
            mu_lo, f_lo, lo_known = mu_hi, f_hi, hi_known
            mu_hi *= 2.0
        if _phi_surely_positive(mu_hi, bound):
            hi_known = False
            continue
        f_hi, t, sig = _rm_phi(mu_hi, c_eig, k_fac, t_tr, lu, evp_n, xs, ys, ds, pt, alpha, visc)
        hi_known = True
        if f_hi <= 0.0:
            break
    else:
        return False, mu_hi, t, sig
    if not lo_known:
        f_lo, t, sig = _rm_phi(mu_lo, c_eig, k_fac, t_tr, lu, evp_n, xs, ys, ds, pt, alpha, visc)
    side = 0
    for _it in range(200):
        mu = (mu_lo * f_hi - mu_hi * f_lo) / (f_hi - f_lo)
        if not (mu_lo < mu < mu_hi):
            mu = 0.5 * (mu_lo + mu_hi)
        fm, t, sig = _rm_phi(mu, c_eig, k_fac, t_tr, lu, evp_n, xs, ys, ds, pt, alpha, visc)
        if abs(fm) < tol or (mu_hi - mu_lo) < 1e-15 * mu_hi:
            return True, mu, t, sig
        if fm > 0.0:
            mu_lo, f_lo = mu, fm
            if side == 1:
                f_hi *= 0.5
            side = 1
        else:
            mu_hi, f_hi = mu, fm
            if side == -1:
                f_lo *= 0.5
            side = -1
    return False, mu_hi, t, sig


@_inner
def _elastic_update(c, q, cel, measure, rot, cr, c_eig):
    """Elastic stress at one point.

    Args:
        c: Eigenvalues of C (3-tuple).
        q: (3, 3) eigenvectors of C (columns).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        rot: (6, 6) scratch (Mandel rotation of the eigenframe).
        cr: (6, 6) scratch.
        c_eig: (6, 6) scratch (stiffness in the eigenframe).

    Returns:
        (status, S as a Mandel 6-tuple in the global frame, zero on failure).
    """
    ok, e_eig, s_fac, _k = _kinematics(c, measure, False)
    if not ok:
        return STATUS_INVERTED, _ZERO6
    _mandel_rotation_into(q, rot)
    # The eigenframe strain has no shear part: T needs the first 3 columns only (the
    # dropped terms are signed zeros, which leave a sum started at +0.0 unchanged).
    _rtcr(rot, cel, cr, c_eig, 3)
    e0, e1, e2 = e_eig[0], e_eig[1], e_eig[2]
    t0 = 0.0 + c_eig[0, 0] * e0 + c_eig[0, 1] * e1 + c_eig[0, 2] * e2
    t1 = 0.0 + c_eig[1, 0] * e0 + c_eig[1, 1] * e1 + c_eig[1, 2] * e2
    t2 = 0.0 + c_eig[2, 0] * e0 + c_eig[2, 1] * e1 + c_eig[2, 2] * e2
    t3 = 0.0 + c_eig[3, 0] * e0 + c_eig[3, 1] * e1 + c_eig[3, 2] * e2
    t4 = 0.0 + c_eig[4, 0] * e0 + c_eig[4, 1] * e1 + c_eig[4, 2] * e2
    t5 = 0.0 + c_eig[5, 0] * e0 + c_eig[5, 1] * e1 + c_eig[5, 2] * e2
    return STATUS_OK, _mv6(rot, _mul6(s_fac, (t0, t1, t2, t3, t4, t5)))


@_inner
def _foam_update(c, q, ep_n, evp_n, pc_n, cel, measure, props, xs, ys, ds, pc_slope, rot, cr,
                 c_eig, lu):
    """Crushable-foam stress update at one point.

    Args:
        c: Eigenvalues of C (3-tuple).
        q: (3, 3) eigenvectors of C (columns).
        ep_n: (6,) converged plastic strain (global Mandel).
        evp_n: Converged volumetric plastic strain.
        pc_n: Compression strength at ``evp_n``.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: [alpha, pt, eta / dt] (the last 0 without viscous regularisation).
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pc_slope: Lipschitz constant of the hardening curve.
        rot: (6, 6) scratch (Mandel rotation of the eigenframe).
        cr: (6, 6) scratch.
        c_eig: (6, 6) scratch (stiffness in the eigenframe).
        lu: (6, 7) scratch for the linear solves.

    Returns:
        (status, S, new plastic strain, new volumetric plastic strain); S (zero on
        failure) and the plastic strain (``ep_n`` unless converged) are global Mandel
        6-tuples.
    """
    ep_old = (ep_n[0], ep_n[1], ep_n[2], ep_n[3], ep_n[4], ep_n[5])
    ok, e_eig, s_fac, k_fac = _kinematics(c, measure, True)
    if not ok:
        return STATUS_INVERTED, _ZERO6, ep_old, evp_n
    _mandel_rotation_into(q, rot)
    _rtcr(rot, cel, cr, c_eig, 6)
    ep_eig = _mtv6(rot, ep_old)
    t_tr = _mv6(c_eig, _sub6(e_eig, ep_eig))
    alpha = props[0]
    pt = props[1]
    visc = props[2]
    f_tr = _foam_yield(_mul6(k_fac, t_tr), pc_n, pt, alpha)
    scale = pc_n + pt
    if f_tr <= 1e-12 * scale:
        return STATUS_OK, _mv6(rot, _mul6(s_fac, t_tr)), ep_old, evp_n
    bound = _phi_bound_data(f_tr, c_eig, k_fac, t_tr, scale, evp_n, pc_slope, alpha, visc)
    converged, mu, t, sig = _return_mapping(f_tr, 1e-13 * scale, bound, c_eig, k_fac, t_tr, lu,
                                            evp_n, xs, ys, ds, pt, alpha, visc)
    if not converged:
        return STATUS_RETURN_MAP, _ZERO6, ep_old, evp_n
    ep_new = _mv6(rot, _axpy6(ep_eig, mu, sig))
    evp = evp_n - mu * (sig[0] + sig[1] + sig[2])
    return STATUS_OK, _mv6(rot, _mul6(s_fac, t)), ep_new, evp


@_inner
def _point_tensors(cmats, ip, h_rel, n, cs):
    """Right Cauchy-Green tensors of the stress updates of point ``ip``.

    Update 0 is the symmetrised C; updates ``2j + 1`` and ``2j + 2`` perturb it so
    that the Green-Lagrange Mandel component j changes by ``+h`` and ``-h``, with
    ``h = h_rel min(1, min_a C_aa)``.

    Args:
        cmats: (n_points, 9) tensors, row-major.
        ip: Point index.
        h_rel: Perturbation size in Green-Lagrange strain (for C near I).
        n: Number of updates (1 or 13).
        cs: (>= n, 3, 3) output: the tensors.

    Returns:
        ``h``.
    """
    for a in range(3):
        for b in range(3):
            cs[0, a, b] = 0.5 * (cmats[ip, 3 * a + b] + cmats[ip, 3 * b + a])
    h = h_rel * min(1.0, min(cs[0, 0, 0], min(cs[0, 1, 1], cs[0, 2, 2])))
    for u in range(1, n):
        sign = 1.0 if u % 2 == 1 else -1.0
        for a in range(3):
            for b in range(3):
                cs[u, a, b] = cs[0, a, b] + sign * 0.0  # C +/- dC, with dC = 0 here
        j = (u - 1) // 2
        a = _MI[j]
        b = _MJ[j]
        if a == b:
            cs[u, a, a] = cs[0, a, a] + sign * (2.0 * h)
        else:
            d = sign * (2.0 * h / SQRT2)
            cs[u, a, b] = cs[0, a, b] + d
            cs[u, b, a] = cs[0, b, a] + d
    return h


@_inner
def _tangent_column(d_out, ip, j, s, sp, sm, okp, okm, h):
    """Write column ``j`` of the finite-difference tangent of point ``ip``.

    Central difference if both perturbed updates succeeded, else one-sided.

    Args:
        d_out: (n, 36) tangent (Mandel, row-major).
        ip: Point index.
        j: Column (perturbed Mandel component).
        s: Stress at C (6-vector).
        sp: Stress at the ``+h`` perturbation (6-vector).
        sm: Stress at the ``-h`` perturbation (6-vector).
        okp: Whether the ``+h`` update succeeded.
        okm: Whether the ``-h`` update succeeded.
        h: Perturbation size.
    """
    for i in range(6):
        if okp and okm:
            d_out[ip, 6 * i + j] = (sp[i] - sm[i]) / (2.0 * h)
        elif okp:
            d_out[ip, 6 * i + j] = (sp[i] - s[i]) / h
        else:
            d_out[ip, 6 * i + j] = (s[i] - sm[i]) / h


@numba.njit(cache=True)
def _new_work():
    """Scratch arrays of the point loops.

    Returns:
        (C of each update, diagonalised C, eigenvectors, Jacobi scratch (two flags,
        cosine and sine), Mandel rotation, ``cel @ rot``, eigenframe stiffness,
        augmented system of the return mapping, stress of each update, their
        success).
    """
    return (np.empty((_NUPD, 3, 3)), np.empty((_NUPD, 3, 3)), np.empty((_NUPD, 3, 3)),
            np.empty(_NUPD, dtype=np.bool_), np.empty(_NUPD, dtype=np.bool_),
            np.empty((_NUPD, 2)), np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)),
            np.empty((6, 7)), np.empty((_NUPD, 6)), np.empty(_NUPD, dtype=np.bool_))


@_inner
def _elastic_points(cmats, cel, measure, s_out, d_out, want_tangent, h_rel, work):
    """Body of :func:`elastic_points`, with its scratch arrays ``work``."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, _lu, s_upd, _ok = work
    nupd = _NUPD if want_tangent else 1
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        h = _point_tensors(cmats, ip, h_rel, nupd, cs)
        eig_sym3(cs, nupd, ms, qs, active, turn, rcs)
        for u in range(nupd):
            c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
            st, s = _elastic_update(c, qs[u], cel, measure, rot, cr, c_eig)
            if u == 0 and st != STATUS_OK:
                nbad += 1
                worst = max(worst, st)
                break
            for i in range(6):
                s_upd[u, i] = s[i]
        else:
            for i in range(6):
                s_out[ip, i] = s_upd[0, i]
            for j in range(nupd // 2):
                _tangent_column(d_out, ip, j, s_upd[0], s_upd[2 * j + 1], s_upd[2 * j + 2],
                                True, True, h)
    return nbad, worst


@numba.njit(cache=True)
def elastic_points(cmats, cel, measure, s_out, d_out, want_tangent, h_rel):
    """Stress and tangent of the elastic solid at every point (no state, no return map).

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (Mandel, row-major).
        want_tangent: Compute ``d_out``.
        h_rel: Perturbation size in Green-Lagrange strain.

    Returns:
        (number of points with a non-zero status, worst status).
    """
    return _elastic_points(cmats, cel, measure, s_out, d_out, want_tangent, h_rel,
                           _new_work())


@_inner
def _foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                 s_out, d_out, ep_out, evp_out, want_tangent, h_rel, work):
    """Body of :func:`foam_points`, with its scratch arrays ``work``."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, lu, s_upd, ok_upd = work
    pc_slope = _hermite_slope_bound(xs, ys, ds)
    nupd = _NUPD if want_tangent else 1
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        h = _point_tensors(cmats, ip, h_rel, nupd, cs)
        eig_sym3(cs, nupd, ms, qs, active, turn, rcs)
        epn = ep_n[ip]
        evpn = evp_n[ip]
        pc_n, _h = hermite_eval(evpn, xs, ys, ds)
        for u in range(nupd):
            c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
            st, s, ep, evp = _foam_update(c, qs[u], epn, evpn, pc_n, cel, measure, props, xs, ys,
                                          ds, pc_slope, rot, cr, c_eig, lu)
            if u == 0:
                if st != STATUS_OK:
                    nbad += 1
                    worst = max(worst, st)
                    break
                for i in range(6):
                    ep_out[ip, i] = ep[i]
                evp_out[ip] = evp
            ok_upd[u] = st == STATUS_OK
            for i in range(6):
                s_upd[u, i] = s[i]
        else:
            for i in range(6):
                s_out[ip, i] = s_upd[0, i]
            for j in range(nupd // 2):
                okp = ok_upd[2 * j + 1]
                okm = ok_upd[2 * j + 2]
                if not (okp or okm):  # both failed: elastic column
                    for u in range(2 * j + 1, 2 * j + 3):
                        c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
                        _st, s = _elastic_update(c, qs[u], cel, measure, rot, cr, c_eig)
                        for i in range(6):
                            s_upd[u, i] = s[i]
                    okp = okm = True
                _tangent_column(d_out, ip, j, s_upd[0], s_upd[2 * j + 1], s_upd[2 * j + 2],
                                okp, okm, h)
    return nbad, worst


@numba.njit(cache=True)
def foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                s_out, d_out, ep_out, evp_out, want_tangent, h_rel):
    """Stress, tangent and trial state of the crushable foam at every point.

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        ep_n: (n, 6) converged plastic strain.
        evp_n: (n,) converged volumetric plastic strain (compression positive).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: [alpha, pt, eta / dt] (the last 0 without viscous regularisation).
        xs: Hardening table abscissae (volumetric plastic strain).
        ys: Hardening table values pc [MPa].
        ds: Hermite slopes of the table.
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (Mandel, row-major).
        ep_out: (n, 6) new plastic strain (a trial, accepted on convergence).
        evp_out: (n,) new volumetric plastic strain.
        want_tangent: Compute ``d_out``.
        h_rel: Perturbation size in Green-Lagrange strain.

    Returns:
        (number of points with a non-zero status, worst status).
    """
    return _foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds, s_out, d_out,
                        ep_out, evp_out, want_tangent, h_rel, _new_work())
