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


@numba.njit(cache=True)
def _dot(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@numba.njit(cache=True)
def _mv(a, x):
    """``a @ x`` for a small dense matrix (no BLAS)."""
    y = np.zeros(a.shape[0])
    for i in range(a.shape[0]):
        s = 0.0
        for j in range(a.shape[1]):
            s += a[i, j] * x[j]
        y[i] = s
    return y


@numba.njit(cache=True)
def _mtv(a, x):
    """``a.T @ x``."""
    y = np.zeros(a.shape[1])
    for j in range(a.shape[1]):
        s = 0.0
        for i in range(a.shape[0]):
            s += a[i, j] * x[i]
        y[j] = s
    return y


@numba.njit(cache=True)
def _mm(a, b):
    """``a @ b``."""
    c = np.zeros((a.shape[0], b.shape[1]))
    for i in range(a.shape[0]):
        for k in range(a.shape[1]):
            aik = a[i, k]
            for j in range(b.shape[1]):
                c[i, j] += aik * b[k, j]
    return c


@numba.njit(cache=True)
def _rtcr(r, c):
    """``r.T @ c @ r``."""
    cr = _mm(c, r)
    out = np.zeros((r.shape[1], r.shape[1]))
    for i in range(r.shape[1]):
        for k in range(r.shape[0]):
            rki = r[k, i]
            for j in range(r.shape[1]):
                out[i, j] += rki * cr[k, j]
    return out


@numba.njit(cache=True)
def eig_sym3(a):
    """Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.

    Returns ``(w, q)`` with eigenvalues ``w`` and eigenvectors as columns of ``q``.
    Robust for repeated eigenvalues (the undeformed state has three).
    """
    m = a.copy()
    q = np.eye(3)
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
    w = np.empty(3)
    for i in range(3):
        w[i] = m[i, i]
    return w, q


@numba.njit(cache=True)
def mandel_rotation(q):
    """6x6 matrix R with ``mandel(q A q^T) = R @ mandel(A)`` (orthogonal)."""
    r = np.empty((6, 6))
    for j in range(6):
        a = _MI[j]
        b = _MJ[j]
        fac = 1.0 if a == b else 1.0 / SQRT2
        for i in range(6):
            k = _MI[i]
            l = _MJ[i]  # noqa: E741
            # (q B q^T)_kl with B = fac (e_a e_b^T + e_b e_a^T) (a != b) or e_a e_a^T
            if a == b:
                v = q[k, a] * q[l, a]
            else:
                v = fac * (q[k, a] * q[l, b] + q[k, b] * q[l, a])
            r[i, j] = v if k == l else SQRT2 * v
    return r


@numba.njit(cache=True)
def strain_f(c, measure):
    """Principal generalised strain for a principal value ``c`` of C."""
    if measure == MEASURE_HENCKY or (measure == MEASURE_BIOT_HENCKY and c < 1.0):
        return 0.5 * math.log(c)
    return math.sqrt(c) - 1.0


@numba.njit(cache=True)
def _theta_hencky(ca, cb):
    x = ca / cb - 1.0
    if abs(x) < 1e-5:
        return (1.0 - 0.5 * x + x * x / 3.0 - 0.25 * x * x * x) / (2.0 * cb)
    return math.log1p(x) / x / (2.0 * cb)


@numba.njit(cache=True)
def strain_theta(ca, cb, measure):
    """Divided difference ``(f(ca) - f(cb)) / (ca - cb)``, ``f'(ca)`` in the limit."""
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


@numba.njit(cache=True)
def _kinematics(cmat, measure):
    """Eigen-frame kinematics of C: strain, rotation, S- and sigma-scalings."""
    c, q = eig_sym3(cmat)
    ok = c[0] > 0.0 and c[1] > 0.0 and c[2] > 0.0
    e_eig = np.zeros(6)
    s_fac = np.zeros(6)
    k_fac = np.zeros(6)
    if not ok:
        return ok, q, e_eig, s_fac, k_fac
    jac = math.sqrt(c[0] * c[1] * c[2])
    for i in range(3):
        e_eig[i] = strain_f(c[i], measure)
    for i in range(6):
        ca = c[_MI[i]]
        cb = c[_MJ[i]]
        th = strain_theta(ca, cb, measure)
        s_fac[i] = 2.0 * th
        k_fac[i] = 2.0 * math.sqrt(ca * cb) * th / jac
    return ok, q, e_eig, s_fac, k_fac


@numba.njit(cache=True)
def _solve_dense(a, b):
    """Solve ``a x = b`` by Gaussian elimination with partial pivoting (small n)."""
    n = b.shape[0]
    m = a.copy()
    x = b.copy()
    for k in range(n):
        p = k
        best = abs(m[k, k])
        for i in range(k + 1, n):
            if abs(m[i, k]) > best:
                best = abs(m[i, k])
                p = i
        if best == 0.0:
            return x, False
        if p != k:
            for j in range(n):
                tmp = m[k, j]
                m[k, j] = m[p, j]
                m[p, j] = tmp
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
        for i in range(k + 1, n):
            f = m[i, k] / m[k, k]
            if f != 0.0:
                for j in range(k, n):
                    m[i, j] -= f * m[k, j]
                x[i] -= f * x[k]
    for k in range(n - 1, -1, -1):
        s = x[k]
        for j in range(k + 1, n):
            s -= m[k, j] * x[j]
        x[k] = s / m[k, k]
    return x, True


@numba.njit(cache=True)
def hermite_eval(x, xs, ys, ds):
    """Piecewise cubic Hermite value and slope; constant below ``xs[0]``, linear above."""
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


@numba.njit(cache=True)
def _foam_yield(sig, pc, pt, alpha):
    """Crushable-foam yield value for a rotated Cauchy stress (Mandel), p > 0 in compression."""
    tr = sig[0] + sig[1] + sig[2]
    p = -tr / 3.0
    q2 = 0.0
    for i in range(6):
        d = sig[i] - (tr / 3.0 if i < 3 else 0.0)
        q2 += d * d
    q2 *= 1.5
    p0 = 0.5 * (pc - pt)
    return math.sqrt(q2 + alpha * alpha * (p - p0) ** 2) - 0.5 * alpha * (pc + pt)


@numba.njit(cache=True)
def _rm_phi(mu, t_tr, c_eig, k_fac, evp_n, xs, ys, ds, pt, alpha, visc, t_out):
    """Yield value after a return of size ``mu``; fills ``t_out`` with the stress.

    The flow is radial in the rotated Cauchy stress (``dg m = mu sigma``), so for a
    given ``mu`` the update ``T = T_tr - mu C K T`` is linear:
    ``T = (I + mu C K)^-1 T_tr`` with ``K = diag(kappa)``. With viscous regularisation
    (``visc = eta / dt > 0``, Duvaut-Lions/Perzyna overstress) the value is
    ``f - visc * dgamma`` with ``dgamma = 2/3 mu g``, ``g = sqrt(3/2 sigma : sigma)``.
    """
    a = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            a[i, j] = mu * c_eig[i, j] * k_fac[j]
        a[i, i] += 1.0
    t, _ok = _solve_dense(a, t_tr)
    for i in range(6):
        t_out[i] = t[i]
    sig = k_fac * t
    evp = evp_n - mu * (sig[0] + sig[1] + sig[2])
    pc, _h = hermite_eval(evp, xs, ys, ds)
    f = _foam_yield(sig, pc, pt, alpha)
    if visc > 0.0:
        f -= visc * (2.0 / 3.0) * mu * math.sqrt(1.5 * _dot(sig, sig))
    return f


@numba.njit(cache=True)
def _elastic_update(cmat, cel, measure):
    """Elastic stress at one point: returns (status, S (Mandel, global))."""
    s_out = np.zeros(6)
    ok, q, e_eig, s_fac, _k = _kinematics(cmat, measure)
    if not ok:
        return STATUS_INVERTED, s_out
    rot = mandel_rotation(q)
    t = _mv(_rtcr(rot, cel), e_eig)
    return STATUS_OK, _mv(rot, s_fac * t)


@numba.njit(cache=True)
def _foam_update(cmat, ep_n, evp_n, cel, measure, props, xs, ys, ds, ep_new):
    """Crushable-foam stress update at one point: returns (status, S, evp_new).

    ``ep_new`` receives the new plastic strain (global Mandel).
    """
    s_out = np.zeros(6)
    ok, q, e_eig, s_fac, k_fac = _kinematics(cmat, measure)
    if not ok:
        return STATUS_INVERTED, s_out, evp_n
    rot = mandel_rotation(q)
    c_eig = _rtcr(rot, cel)
    ep_eig = _mtv(rot, ep_n)
    t_tr = _mv(c_eig, e_eig - ep_eig)
    pt = props[1]
    alpha = props[0]
    visc = props[2]
    pc_n, _h = hermite_eval(evp_n, xs, ys, ds)
    sig = k_fac * t_tr
    f_tr = _foam_yield(sig, pc_n, pt, alpha)
    scale = pc_n + pt
    if f_tr <= 1e-12 * scale:
        s_out = _mv(rot, s_fac * t_tr)
        for i in range(6):
            ep_new[i] = ep_n[i]
        return STATUS_OK, s_out, evp_n
    # Return mapping: the smallest root mu > 0 of phi(mu) = f(sigma(mu), pc(evp(mu))),
    # bracketed by geometric search from phi(0) > 0, then Illinois regula falsi.
    t = np.zeros(6)
    cmax = 0.0
    for i in range(6):
        cmax = max(cmax, c_eig[i, i] * k_fac[i])
    tol = 1e-13 * scale
    mu_lo, f_lo = 0.0, f_tr
    mu_hi = 1e-4 / cmax
    f_hi = _rm_phi(mu_hi, t_tr, c_eig, k_fac, evp_n, xs, ys, ds, pt, alpha, visc, t)
    converged = False
    for _b in range(80):
        if f_hi <= 0.0:
            break
        mu_lo, f_lo = mu_hi, f_hi
        mu_hi *= 2.0
        f_hi = _rm_phi(mu_hi, t_tr, c_eig, k_fac, evp_n, xs, ys, ds, pt, alpha, visc, t)
    mu = mu_hi
    if f_hi <= 0.0:
        side = 0
        for _it in range(200):
            mu = (mu_lo * f_hi - mu_hi * f_lo) / (f_hi - f_lo)
            if not (mu_lo < mu < mu_hi):
                mu = 0.5 * (mu_lo + mu_hi)
            fm = _rm_phi(mu, t_tr, c_eig, k_fac, evp_n, xs, ys, ds, pt, alpha, visc, t)
            if abs(fm) < tol or (mu_hi - mu_lo) < 1e-15 * mu_hi:
                converged = True
                break
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
    if not converged:
        return STATUS_RETURN_MAP, s_out, evp_n
    sig = k_fac * t
    ep_glob = _mv(rot, ep_eig + mu * sig)
    for i in range(6):
        ep_new[i] = ep_glob[i]
    s_out = _mv(rot, s_fac * t)
    return STATUS_OK, s_out, evp_n - mu * (sig[0] + sig[1] + sig[2])


@numba.njit(cache=True)
def _perturbation(cm, h_rel, j):
    """Symmetric perturbation of C that changes Green-Lagrange Mandel component j by h."""
    cmin = min(cm[0, 0], min(cm[1, 1], cm[2, 2]))
    h = h_rel * min(1.0, cmin)
    a = _MI[j]
    b = _MJ[j]
    dc = np.zeros((3, 3))
    if a == b:
        dc[a, a] = 2.0 * h
    else:
        dc[a, b] = 2.0 * h / SQRT2
        dc[b, a] = 2.0 * h / SQRT2
    return dc, h


@numba.njit(cache=True)
def _cauchy_green(cmats, ip):
    cm = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            cm[a, b] = 0.5 * (cmats[ip, 3 * a + b] + cmats[ip, 3 * b + a])
    return cm


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
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        cm = _cauchy_green(cmats, ip)
        st, s = _elastic_update(cm, cel, measure)
        if st != STATUS_OK:
            nbad += 1
            worst = max(worst, st)
            continue
        for i in range(6):
            s_out[ip, i] = s[i]
        if not want_tangent:
            continue
        for j in range(6):
            dc, h = _perturbation(cm, h_rel, j)
            _stp, sp = _elastic_update(cm + dc, cel, measure)
            _stm, sm = _elastic_update(cm - dc, cel, measure)
            for i in range(6):
                d_out[ip, 6 * i + j] = (sp[i] - sm[i]) / (2.0 * h)
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
    nbad = 0
    worst = 0
    ep_tmp = np.zeros(6)
    for ip in range(cmats.shape[0]):
        cm = _cauchy_green(cmats, ip)
        st, s, evp = _foam_update(cm, ep_n[ip], evp_n[ip], cel, measure, props, xs, ys, ds,
                                  ep_tmp)
        if st != STATUS_OK:
            nbad += 1
            worst = max(worst, st)
            continue
        for i in range(6):
            s_out[ip, i] = s[i]
            ep_out[ip, i] = ep_tmp[i]
        evp_out[ip] = evp
        if not want_tangent:
            continue
        for j in range(6):
            dc, h = _perturbation(cm, h_rel, j)
            stp, sp, _e = _foam_update(cm + dc, ep_n[ip], evp_n[ip], cel, measure, props,
                                       xs, ys, ds, ep_tmp)
            stm, sm, _e = _foam_update(cm - dc, ep_n[ip], evp_n[ip], cel, measure, props,
                                       xs, ys, ds, ep_tmp)
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
                _a, sp = _elastic_update(cm + dc, cel, measure)
                _b, sm = _elastic_update(cm - dc, cel, measure)
                for i in range(6):
                    d_out[ip, 6 * i + j] = (sp[i] - sm[i]) / (2.0 * h)
    return nbad, worst
