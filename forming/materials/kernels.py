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

Performance: a kernel call allocates one set of scratch arrays (:class:`Work`) and
every point update writes into it, so the inner functions allocate nothing. Their
floating-point operations are those of the plain formulation, in the same order:
the finite-difference tangent divides round-off in ``S`` by ``h``, so even a
reordered sum would change ``D`` visibly.
"""

from __future__ import annotations

import math
from typing import NamedTuple

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


class Work(NamedTuple):
    """Scratch arrays of the point updates, allocated once per kernel call.

    Attributes:
        cm: (3, 3) right Cauchy-Green tensor of the current point.
        cp: (3, 3) perturbed right Cauchy-Green tensor (tangent).
        jac: (3, 3) Jacobi iterate of the eigen solver.
        q: (3, 3) eigenvectors of C (columns).
        c: (3,) eigenvalues of C.
        e_eig: (6,) strain in the eigenframe.
        s_fac: (6,) S-scalings ``2 theta_ab``.
        k_fac: (6,) sigma-scalings ``kappa_ab``.
        rot: (6, 6) Mandel rotation of the eigenframe.
        cr: (6, 6) ``cel @ rot``.
        c_eig: (6, 6) elastic stiffness in the eigenframe, ``rot.T @ cel @ rot``.
        ep_eig: (6,) plastic strain in the eigenframe.
        vec: (6,) operand of a rotation or matrix-vector product.
        t_tr: (6,) trial stress T in the eigenframe.
        t: (6,) stress T after a return of trial size ``mu``.
        sig: (6,) rotated Cauchy stress in the eigenframe.
        lu: (6, 6) matrix being eliminated by :func:`_solve6`.
        s: (6,) stress S at the point.
        sp: (6,) stress S at ``C + dC``.
        sm: (6,) stress S at ``C - dC``.
        ep_new: (6,) new plastic strain (global).
    """

    cm: np.ndarray
    cp: np.ndarray
    jac: np.ndarray
    q: np.ndarray
    c: np.ndarray
    e_eig: np.ndarray
    s_fac: np.ndarray
    k_fac: np.ndarray
    rot: np.ndarray
    cr: np.ndarray
    c_eig: np.ndarray
    ep_eig: np.ndarray
    vec: np.ndarray
    t_tr: np.ndarray
    t: np.ndarray
    sig: np.ndarray
    lu: np.ndarray
    s: np.ndarray
    sp: np.ndarray
    sm: np.ndarray
    ep_new: np.ndarray


@numba.njit(cache=True, error_model="numpy", inline="always")
def _new_work():
    """Allocate the scratch arrays of one kernel call.

    Returns:
        A :class:`Work` of zero-filled arrays.
    """
    return Work(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)),
                np.zeros(3), np.zeros(6), np.zeros(6), np.zeros(6), np.zeros((6, 6)),
                np.zeros((6, 6)), np.zeros((6, 6)), np.zeros(6), np.zeros(6), np.zeros(6),
                np.zeros(6), np.zeros(6), np.zeros((6, 6)), np.zeros(6), np.zeros(6),
                np.zeros(6), np.zeros(6))


@numba.njit(cache=True, error_model="numpy", inline="always")
def _mv6(a, x, y):
    """Write ``a @ x`` into ``y`` for a 6x6 matrix (no BLAS).

    Args:
        a: (6, 6) matrix.
        x: (6,) vector.
        y: (6,) output, distinct from ``x``.
    """
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += a[i, j] * x[j]
        y[i] = s


@numba.njit(cache=True, error_model="numpy", inline="always")
def _mtv6(a, x, y):
    """Write ``a.T @ x`` into ``y`` for a 6x6 matrix.

    Args:
        a: (6, 6) matrix.
        x: (6,) vector.
        y: (6,) output, distinct from ``x``.
    """
    for j in range(6):
        s = 0.0
        for i in range(6):
            s += a[i, j] * x[i]
        y[j] = s


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rtcr(r, c, cr, out, ncol):
    """Write the first ``ncol`` columns of ``r.T @ c @ r`` into ``out`` (6x6 matrices).

    Args:
        r: (6, 6) rotation.
        c: (6, 6) matrix to rotate.
        cr: (6, 6) scratch; its first ``ncol`` columns receive ``c @ r``.
        out: (6, 6) output; columns ``ncol`` and beyond are left as they are.
        ncol: Number of columns wanted (the elastic update needs only 3).
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


@numba.njit(cache=True, error_model="numpy", inline="always")
def eig_sym3(a, m, q, w):
    """Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.

    Robust for repeated eigenvalues (the undeformed state has three).

    Args:
        a: (3, 3) symmetric matrix (not modified).
        m: (3, 3) scratch for the Jacobi iterate.
        q: (3, 3) output: eigenvectors as columns.
        w: (3,) output: eigenvalues.
    """
    for i in range(3):
        for j in range(3):
            m[i, j] = a[i, j]
            q[i, j] = 1.0 if i == j else 0.0
    for _sweep in range(50):
        off = m[0, 1] ** 2 + m[0, 2] ** 2 + m[1, 2] ** 2
        scale = m[0, 0] ** 2 + m[1, 1] ** 2 + m[2, 2] ** 2
        if off <= 1e-30 * scale or off == 0.0:
            break
        for p in range(2):
            for r in range(p + 1, 3):
                apr = m[p, r]
                if apr == 0.0:
                    continue
                theta = (m[r, r] - m[p, p]) / (2.0 * apr)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(3):
                    mkp = m[k, p]
                    mkr = m[k, r]
                    m[k, p] = c * mkp - s * mkr
                    m[k, r] = s * mkp + c * mkr
                for k in range(3):
                    mpk = m[p, k]
                    mrk = m[r, k]
                    m[p, k] = c * mpk - s * mrk
                    m[r, k] = s * mpk + c * mrk
                for k in range(3):
                    qkp = q[k, p]
                    qkr = q[k, r]
                    q[k, p] = c * qkp - s * qkr
                    q[k, r] = s * qkp + c * qkr
    for i in range(3):
        w[i] = m[i, i]


@numba.njit(cache=True, error_model="numpy", inline="always")
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


@numba.njit(cache=True, error_model="numpy", inline="always")
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


@numba.njit(cache=True, error_model="numpy", inline="always")
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


@numba.njit(cache=True, error_model="numpy", inline="always")
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


@numba.njit(cache=True, error_model="numpy", inline="always")
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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _kinematics(cmat, measure, w):
    """Eigen-frame kinematics of C: strain, rotation, S- and sigma-scalings.

    Args:
        cmat: (3, 3) right Cauchy-Green tensor.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        w: Work arrays; fills ``q``, ``c``, ``e_eig``, ``s_fac`` and ``k_fac``
            (only ``q`` and ``c`` if C is not positive definite).

    Returns:
        Whether C is positive definite.
    """
    c = w.c
    eig_sym3(cmat, w.jac, w.q, c)
    if not (c[0] > 0.0 and c[1] > 0.0 and c[2] > 0.0):
        return False
    jac = math.sqrt(c[0] * c[1] * c[2])
    for i in range(3):
        w.e_eig[i] = strain_f(c[i], measure)
        w.e_eig[i + 3] = 0.0
    for i in range(6):
        ca = c[_MI[i]]
        cb = c[_MJ[i]]
        th = strain_theta(ca, cb, measure)
        w.s_fac[i] = 2.0 * th
        w.k_fac[i] = 2.0 * math.sqrt(ca * cb) * th / jac
    return True


@numba.njit(cache=True, error_model="numpy", inline="always")
def _solve6(m, x):
    """Solve ``m y = x`` in place by Gaussian elimination with partial pivoting (6x6).

    Args:
        m: (6, 6) matrix, overwritten by its elimination.
        x: (6,) right-hand side, overwritten by the solution (by the partly
            eliminated right-hand side if ``m`` is singular).

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
            for j in range(6):
                tmp = m[k, j]
                m[k, j] = m[p, j]
                m[p, j] = tmp
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
        for i in range(k + 1, 6):
            f = m[i, k] / m[k, k]
            if f != 0.0:
                for j in range(k, 6):
                    m[i, j] -= f * m[k, j]
                x[i] -= f * x[k]
    for k in range(5, -1, -1):
        s = x[k]
        for j in range(k + 1, 6):
            s -= m[k, j] * x[j]
        x[k] = s / m[k, k]
    return True


@numba.njit(cache=True, error_model="numpy", inline="always")
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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _foam_yield(sig, pc, pt, alpha):
    """Crushable-foam yield value for a rotated Cauchy stress, p > 0 in compression.

    Args:
        sig: (6,) rotated Cauchy stress (Mandel).
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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rm_phi(mu, w, evp_n, xs, ys, ds, pt, alpha):
    """Yield value after a return of size ``mu``.

    The flow is radial in the rotated Cauchy stress (``dg m = mu sigma``), so for a
    given ``mu`` the update ``T = T_tr - mu C K T`` is linear:
    ``T = (I + mu C K)^-1 T_tr`` with ``K = diag(kappa)``.

    Args:
        mu: Return size.
        w: Work arrays; reads ``c_eig``, ``k_fac``, ``t_tr``, fills ``t`` (the
            stress T), ``sig`` and ``lu``.
        evp_n: Converged volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.

    Returns:
        The yield value at the returned stress and hardened ``pc``.
    """
    a = w.lu
    t = w.t
    sig = w.sig
    for i in range(6):
        for j in range(6):
            a[i, j] = mu * w.c_eig[i, j] * w.k_fac[j]
        a[i, i] += 1.0
        t[i] = w.t_tr[i]
    _solve6(a, t)
    for i in range(6):
        sig[i] = w.k_fac[i] * t[i]
    evp = evp_n - mu * (sig[0] + sig[1] + sig[2])
    pc, _h = hermite_eval(evp, xs, ys, ds)
    return _foam_yield(sig, pc, pt, alpha)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _return_mapping(f_tr, tol, w, evp_n, xs, ys, ds, pt, alpha):
    """Smallest root ``mu > 0`` of ``phi(mu) = f(sigma(mu), pc(evp(mu)))``.

    Bracketed by geometric search from ``phi(0) = f_tr > 0``, then Illinois
    regula falsi.

    Args:
        f_tr: Trial yield value (positive).
        tol: Tolerance on ``|phi|``.
        w: Work arrays (see :func:`_rm_phi`); on convergence ``t`` and ``sig``
            hold the returned state.
        evp_n: Converged volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.

    Returns:
        (converged, mu).
    """
    cmax = 0.0
    for i in range(6):
        cmax = max(cmax, w.c_eig[i, i] * w.k_fac[i])
    mu_lo, f_lo = 0.0, f_tr
    mu_hi = 1e-4 / cmax
    f_hi = _rm_phi(mu_hi, w, evp_n, xs, ys, ds, pt, alpha)
    for _b in range(80):
        if f_hi <= 0.0:
            break
        mu_lo, f_lo = mu_hi, f_hi
        mu_hi *= 2.0
        f_hi = _rm_phi(mu_hi, w, evp_n, xs, ys, ds, pt, alpha)
    if f_hi > 0.0:
        return False, mu_hi
    side = 0
    for _it in range(200):
        mu = (mu_lo * f_hi - mu_hi * f_lo) / (f_hi - f_lo)
        if not (mu_lo < mu < mu_hi):
            mu = 0.5 * (mu_lo + mu_hi)
        fm = _rm_phi(mu, w, evp_n, xs, ys, ds, pt, alpha)
        if abs(fm) < tol or (mu_hi - mu_lo) < 1e-15 * mu_hi:
            return True, mu
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
    return False, mu_hi


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rotate_back(w, t, s_out):
    """Write the global stress ``S = R (s_fac * T)`` into ``s_out``.

    Args:
        w: Work arrays (reads ``rot`` and ``s_fac``, uses ``vec``).
        t: (6,) stress T in the eigenframe.
        s_out: (6,) output.
    """
    for i in range(6):
        w.vec[i] = w.s_fac[i] * t[i]
    _mv6(w.rot, w.vec, s_out)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _elastic_update(cmat, cel, measure, w, s_out):
    """Elastic stress at one point.

    Args:
        cmat: (3, 3) right Cauchy-Green tensor.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        w: Work arrays.
        s_out: (6,) output: S (Mandel, global), zero on failure.

    Returns:
        The status.
    """
    if not _kinematics(cmat, measure, w):
        s_out[:] = 0.0
        return STATUS_INVERTED
    _mandel_rotation_into(w.q, w.rot)
    # The eigenframe strain has no shear, so T needs the first 3 columns only.
    _rtcr(w.rot, cel, w.cr, w.c_eig, 3)
    for i in range(6):
        s = 0.0
        for j in range(3):
            s += w.c_eig[i, j] * w.e_eig[j]
        w.t[i] = s
    _rotate_back(w, w.t, s_out)
    return STATUS_OK


@numba.njit(cache=True, error_model="numpy", inline="always")
def _foam_update(cmat, ep_n, evp_n, pc_n, cel, measure, props, xs, ys, ds, w, s_out, ep_new):
    """Crushable-foam stress update at one point.

    Args:
        cmat: (3, 3) right Cauchy-Green tensor.
        ep_n: (6,) converged plastic strain (global Mandel).
        evp_n: Converged volumetric plastic strain.
        pc_n: Compression strength at ``evp_n``.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: [alpha, pt].
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        w: Work arrays.
        s_out: (6,) output: S (Mandel, global), zero on failure.
        ep_new: (6,) output: new plastic strain (global Mandel), set on success.

    Returns:
        (status, new volumetric plastic strain).
    """
    if not _kinematics(cmat, measure, w):
        s_out[:] = 0.0
        return STATUS_INVERTED, evp_n
    _mandel_rotation_into(w.q, w.rot)
    _rtcr(w.rot, cel, w.cr, w.c_eig, 6)
    _mtv6(w.rot, ep_n, w.ep_eig)
    for i in range(6):
        w.vec[i] = w.e_eig[i] - w.ep_eig[i]
    _mv6(w.c_eig, w.vec, w.t_tr)
    alpha = props[0]
    pt = props[1]
    for i in range(6):
        w.sig[i] = w.k_fac[i] * w.t_tr[i]
    f_tr = _foam_yield(w.sig, pc_n, pt, alpha)
    scale = pc_n + pt
    if f_tr <= 1e-12 * scale:
        _rotate_back(w, w.t_tr, s_out)
        ep_new[:] = ep_n
        return STATUS_OK, evp_n
    converged, mu = _return_mapping(f_tr, 1e-13 * scale, w, evp_n, xs, ys, ds, pt, alpha)
    if not converged:
        s_out[:] = 0.0
        return STATUS_RETURN_MAP, evp_n
    sig = w.sig
    for i in range(6):
        w.vec[i] = w.ep_eig[i] + mu * sig[i]
    _mv6(w.rot, w.vec, ep_new)
    _rotate_back(w, w.t, s_out)
    return STATUS_OK, evp_n - mu * (sig[0] + sig[1] + sig[2])


@numba.njit(cache=True, error_model="numpy", inline="always")
def _perturb(cm, h_rel, j, sign, cp):
    """Perturb C so that Green-Lagrange Mandel component j changes by ``sign * h``.

    Args:
        cm: (3, 3) right Cauchy-Green tensor.
        h_rel: Perturbation size in Green-Lagrange strain (for C near I).
        j: Mandel component.
        sign: +1.0 or -1.0.
        cp: (3, 3) output: the perturbed tensor.

    Returns:
        ``h``, the perturbation size scaled by the smallest diagonal entry of C.
    """
    cmin = min(cm[0, 0], min(cm[1, 1], cm[2, 2]))
    h = h_rel * min(1.0, cmin)
    a = _MI[j]
    b = _MJ[j]
    for k in range(3):
        for m in range(3):
            cp[k, m] = cm[k, m]
    if a == b:
        cp[a, a] = cm[a, a] + sign * (2.0 * h)
    else:
        d = sign * (2.0 * h / SQRT2)
        cp[a, b] = cm[a, b] + d
        cp[b, a] = cm[b, a] + d
    return h


@numba.njit(cache=True, error_model="numpy", inline="always")
def _cauchy_green(cmats, ip, cm):
    """Symmetrised right Cauchy-Green tensor of point ``ip``.

    Args:
        cmats: (n, 9) tensors, row-major.
        ip: Point index.
        cm: (3, 3) output.
    """
    for a in range(3):
        for b in range(3):
            cm[a, b] = 0.5 * (cmats[ip, 3 * a + b] + cmats[ip, 3 * b + a])


@numba.njit(cache=True, error_model="numpy")
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
    nbad = 0
    worst = 0
    w = _new_work()
    for ip in range(cmats.shape[0]):
        _cauchy_green(cmats, ip, w.cm)
        st = _elastic_update(w.cm, cel, measure, w, w.s)
        if st != STATUS_OK:
            nbad += 1
            worst = max(worst, st)
            continue
        for i in range(6):
            s_out[ip, i] = w.s[i]
        if not want_tangent:
            continue
        for j in range(6):
            h = _perturb(w.cm, h_rel, j, 1.0, w.cp)
            _elastic_update(w.cp, cel, measure, w, w.sp)
            _perturb(w.cm, h_rel, j, -1.0, w.cp)
            _elastic_update(w.cp, cel, measure, w, w.sm)
            for i in range(6):
                d_out[ip, 6 * i + j] = (w.sp[i] - w.sm[i]) / (2.0 * h)
    return nbad, worst


@numba.njit(cache=True, error_model="numpy")
def foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                s_out, d_out, ep_out, evp_out, want_tangent, h_rel):
    """Stress, tangent and trial state of the crushable foam at every point.

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        ep_n: (n, 6) converged plastic strain.
        evp_n: (n,) converged volumetric plastic strain (compression positive).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: [alpha, pt].
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
    nbad = 0
    worst = 0
    w = _new_work()
    s, sp, sm = w.s, w.sp, w.sm
    for ip in range(cmats.shape[0]):
        _cauchy_green(cmats, ip, w.cm)
        epn = ep_n[ip]
        evpn = evp_n[ip]
        pc_n, _h = hermite_eval(evpn, xs, ys, ds)
        st, evp = _foam_update(w.cm, epn, evpn, pc_n, cel, measure, props, xs, ys, ds, w, s,
                               w.ep_new)
        if st != STATUS_OK:
            nbad += 1
            worst = max(worst, st)
            continue
        for i in range(6):
            s_out[ip, i] = s[i]
            ep_out[ip, i] = w.ep_new[i]
        evp_out[ip] = evp
        if not want_tangent:
            continue
        for j in range(6):
            h = _perturb(w.cm, h_rel, j, 1.0, w.cp)
            stp, _e = _foam_update(w.cp, epn, evpn, pc_n, cel, measure, props, xs, ys, ds, w,
                                   sp, w.ep_new)
            _perturb(w.cm, h_rel, j, -1.0, w.cp)
            stm, _e = _foam_update(w.cp, epn, evpn, pc_n, cel, measure, props, xs, ys, ds, w,
                                   sm, w.ep_new)
            if stp == STATUS_OK and stm == STATUS_OK:
                for i in range(6):
                    d_out[ip, 6 * i + j] = (sp[i] - sm[i]) / (2.0 * h)
            elif stp == STATUS_OK:  # one side failed: one-sided difference
                for i in range(6):
                    d_out[ip, 6 * i + j] = (sp[i] - s[i]) / h
            elif stm == STATUS_OK:
                for i in range(6):
                    d_out[ip, 6 * i + j] = (s[i] - sm[i]) / h
            else:  # both failed: elastic column
                _perturb(w.cm, h_rel, j, 1.0, w.cp)
                _elastic_update(w.cp, cel, measure, w, sp)
                _perturb(w.cm, h_rel, j, -1.0, w.cp)
                _elastic_update(w.cp, cel, measure, w, sm)
                for i in range(6):
                    d_out[ip, 6 * i + j] = (sp[i] - sm[i]) / (2.0 * h)
    return nbad, worst
