"""Closed-form consistent tangent ``dS/dE_GL`` of the Seth-Hill strain materials.

Everything is linearised in the eigenframe of C at the evaluated point (a fixed
orthonormal basis), then rotated to the global frame: ``D = R (2 dS/dc) R^T`` with
``R`` the Mandel rotation of the eigenframe and ``dc`` the change of C.

* Strain: ``dE = Theta dc``, ``Theta = diag(theta_ab)`` (first divided differences
  of ``f``, Daleckii-Krein).
* Stress: ``S = 2 Theta T``, so ``dS = 2 Theta dT + G_S dc``; the geometric term at
  fixed ``T`` is ``(G_S dc)_pq = 2 sum_b T_pb f2(p, q, b) dC_qb + 2 sum_a dC_pa T_aq
  f2(a, p, q)`` with ``f2`` the second divided differences of ``f`` (Daleckii-Krein
  of second order; this is ``T : L`` of Miehe & Lambrecht 2001, and its equal-
  eigenvalue branches are the limits of ``f2``, :func:`strain_f2`, computed from the
  first divided differences the stress already needs).
* Elastic (or frozen foam): ``dT = C_e Theta dc``.
* Crushable foam after a return of size ``mu``: the local equations
  ``T + mu C_e sigma(T, C) = C_e (E(C) - E_p)`` and ``phi(sigma, pc(evp)) - visc
  2/3 mu g(sigma) = 0`` (``evp = evp_n - mu tr sigma``) are linearised in ``(T, mu)``
  and C and solved as one 7x7 system for the six directions of ``dc``. The rotated
  Cauchy stress ``sigma = U S U / J`` depends on C beyond the strain; its derivative
  at fixed T (``G_K``) is part of the system, so the tangent is exact.
"""

from __future__ import annotations

import math

from .common import _inner
from .curve import hermite_eval
from .foam import PROP_ALPHA, PROP_PT, PROP_VISC, _yield_radius
from .mandel import _MI, _MJ, SQRT2, _dot6, _is_isotropic
from .strain import MEASURE_BIOT, MEASURE_BIOT_HENCKY, MEASURE_HENCKY

_INV_SQRT2 = 1.0 / SQRT2


@_inner
def _f2_hencky(x, y, z, th_hm, th_ml):
    """Second divided difference of ``f(c) = ln(c)/2``.

    From the first divided differences when the arguments spread by more than 1e-4
    of the largest (a relative round-off below about 1e-12), else from the Taylor
    series about their mean (to third order: truncation below 1e-16).

    Args:
        x: Largest argument (positive).
        y: Middle argument.
        z: Smallest argument.
        th_hm: ``f[x, y]``.
        th_ml: ``f[y, z]``.

    Returns:
        ``f[x, y, z]``.
    """
    if x - z > 1e-4 * x:
        return (th_hm - th_ml) / (x - z)
    m = (x + y + z) / 3.0
    d0, d1, d2 = x - m, y - m, z - m
    p2 = d0 * d0 + d1 * d1 + d2 * d2
    p3 = d0 * d0 * d0 + d1 * d1 * d1 + d2 * d2 * d2
    im = 1.0 / m
    im2 = im * im
    return -0.25 * im2 + p2 * im2 * im2 / 16.0 - p3 * im2 * im2 * im / 30.0


@_inner
def strain_f2(x, y, z, th_hm, th_ml, measure):
    """Second divided difference ``f[x, y, z]`` of the principal strain function.

    Args:
        x: Largest eigenvalue of the three.
        y: Middle one.
        z: Smallest one.
        th_hm: First divided difference ``f[x, y]`` (:func:`.strain.strain_theta`).
        th_ml: ``f[y, z]``.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).

    Returns:
        ``f[x, y, z]`` (``f''(x) / 2`` when all three are equal).
    """
    if measure == MEASURE_BIOT or (measure == MEASURE_BIOT_HENCKY and z >= 1.0):
        # f[x, y] = 1 / (sqrt x + sqrt y): exact, no cancellation
        return -th_hm * th_ml / (math.sqrt(x) + math.sqrt(z))
    if measure == MEASURE_HENCKY or x < 1.0:
        return _f2_hencky(x, y, z, th_hm, th_ml)
    # Biot-Hencky across 1: the branches meet with equal slopes, different curvatures
    if x - z > 1e-8:
        return (th_hm - th_ml) / (x - z)
    return -0.1875  # mean of f''(1)/2 of the two branches (-1/8 and -1/4)


@_inner
def _sym33(v, out):
    """Write the 3x3 tensor of a Mandel 6-vector ``v`` into ``out``."""
    out[0, 0] = v[0]
    out[1, 1] = v[1]
    out[2, 2] = v[2]
    out[1, 2] = out[2, 1] = v[3] * _INV_SQRT2
    out[0, 2] = out[2, 0] = v[4] * _INV_SQRT2
    out[0, 1] = out[1, 0] = v[5] * _INV_SQRT2


@_inner
def _unit33(n, out):
    """Write the tensor of the Mandel unit vector ``e_n`` into ``out``."""
    for a in range(3):
        for b in range(3):
            out[a, b] = 0.0
    a = _MI[n]
    b = _MJ[n]
    if a == b:
        out[a, a] = 1.0
    else:
        out[a, b] = out[b, a] = _INV_SQRT2


@_inner
def geometric_terms(c, t, s_fac, sig, measure, want_gk, w):
    """``G_S`` and (if ``want_gk``) ``G_K`` in the eigenframe, into ``w.gs``, ``w.gk``.

    Args:
        c: Eigenvalues of C (3-tuple).
        t: Stress T in the eigenframe (Mandel 6-tuple).
        s_fac: S-scalings ``2 theta`` (Mandel 6-tuple).
        sig: Rotated Cauchy stress in the eigenframe (Mandel 6-tuple; unused unless
            ``want_gk``).
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        want_gk: Compute ``G_K`` (the derivative of sigma at fixed T).
        w: Scratch (:class:`TangentWork` arrays: f2, t33, k33, x33, s33, sg33, gs, gk).
    """
    f2, t33, k33, x33, s33, sg33, gs, gk = w
    # first divided differences by index pair, from the S-scalings 2 theta
    th = ((0.5 * s_fac[0], 0.5 * s_fac[5], 0.5 * s_fac[4]),
          (0.5 * s_fac[5], 0.5 * s_fac[1], 0.5 * s_fac[3]),
          (0.5 * s_fac[4], 0.5 * s_fac[3], 0.5 * s_fac[2]))
    for a in range(3):
        for b in range(a, 3):
            for e in range(b, 3):
                v = _f2_sorted(c, th, a, b, e, measure)
                f2[a, b, e] = f2[a, e, b] = f2[b, a, e] = v
                f2[b, e, a] = f2[e, a, b] = f2[e, b, a] = v
    _sym33(t, t33)
    lam0, lam1, lam2 = math.sqrt(c[0]), math.sqrt(c[1]), math.sqrt(c[2])
    lam = (lam0, lam1, lam2)
    jac = lam0 * lam1 * lam2
    if want_gk:
        _sym33((s_fac[0] * t[0], s_fac[1] * t[1], s_fac[2] * t[2], s_fac[3] * t[3],
                s_fac[4] * t[4], s_fac[5] * t[5]), s33)
        _sym33(sig, sg33)
    for n in range(6):
        _unit33(n, k33)
        # X = T : L[dC] / 2 for dC = e_n (symmetric). With K = dC, X_pq = sum_b T_pb
        # f2(p, q, b) K_qb + sum_b K_pb T_bq f2(b, p, q); K has one or two non-zeros, so
        # only the rows and columns of its indices a, b receive terms.
        for p in range(3):
            for q in range(3):
                x33[p, q] = 0.0
        a = _MI[n]
        b = _MJ[n]
        if a == b:
            for p in range(3):
                x33[p, a] += t33[p, a] * f2[p, a, a]
                x33[a, p] += t33[a, p] * f2[a, a, p]
        else:
            for p in range(3):
                x33[p, a] += _INV_SQRT2 * t33[p, b] * f2[p, a, b]
                x33[p, b] += _INV_SQRT2 * t33[p, a] * f2[p, b, a]
                x33[a, p] += _INV_SQRT2 * t33[b, p] * f2[b, a, p]
                x33[b, p] += _INV_SQRT2 * t33[a, p] * f2[a, b, p]
        for m in range(6):
            p = _MI[m]
            q = _MJ[m]
            gs[m, n] = 2.0 * x33[p, q] * (1.0 if p == q else SQRT2)
        if not want_gk:
            continue
        djj = 0.5 * (k33[0, 0] / c[0] + k33[1, 1] / c[1] + k33[2, 2] / c[2])
        for m in range(6):
            p = _MI[m]
            q = _MJ[m]
            v = 2.0 * lam[p] * lam[q] * x33[p, q]
            for e in range(3):
                v += (k33[p, e] / (lam[p] + lam[e]) * s33[e, q] * lam[q]
                      + lam[p] * s33[p, e] * k33[e, q] / (lam[e] + lam[q]))
            v = v / jac - sg33[p, q] * djj
            gk[m, n] = v * (1.0 if p == q else SQRT2)


@_inner
def _solve_multi(a, n, nrhs):
    """Solve ``a[:, :n] X = a[:, n:n+nrhs]`` in place (Gaussian elimination, pivoting).

    Args:
        a: (n, n + nrhs) augmented matrix; the right-hand sides receive X.
        n: Size of the system.
        nrhs: Number of right-hand sides.

    Returns:
        False if a zero pivot was met.
    """
    ncol = n + nrhs
    for k in range(n):
        p = k
        best = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > best:
                best = abs(a[i, k])
                p = i
        if best == 0.0:
            return False
        if p != k:
            for j in range(k, ncol):
                tmp = a[k, j]
                a[k, j] = a[p, j]
                a[p, j] = tmp
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            f = a[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, ncol):
                    a[i, j] -= f * a[k, j]
    for r in range(n, ncol):
        for k in range(n - 1, -1, -1):
            s = a[k, r]
            for j in range(k + 1, n):
                s -= a[k, j] * a[j, r]
            a[k, r] = s / a[k, k]
    return True


@_inner
def _write_global(d_out, ip, rot, mt, tmp):
    """``d_out[ip] = R (2 mt) R^T`` (row-major Mandel), ``mt = dS/dc`` in the eigenframe."""
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += mt[i, k] * rot[j, k]
            tmp[i, j] = s
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += rot[i, k] * tmp[k, j]
            d_out[ip, 6 * i + j] = 2.0 * s


@_inner
def elastic_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, w, mt, tmp):
    """Closed-form tangent of an elastic point (or a foam point that stays elastic).

    ``dS/dc = 2 Theta C_e Theta + G_S`` in the eigenframe.

    Args:
        d_out: (n, 36) tangent output.
        ip: Point index.
        c: Eigenvalues of C (3-tuple).
        t: Stress T in the eigenframe (Mandel 6-tuple).
        s_fac: S-scalings ``2 theta`` (Mandel 6-tuple).
        c_eig: (6, 6) elastic stiffness in the eigenframe (all six columns).
        rot: (6, 6) Mandel rotation of the eigenframe.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        w: Scratch of :func:`geometric_terms`.
        mt: (6, 6) scratch.
        tmp: (6, 6) scratch.
    """
    tiny = 1e-14 * max(abs(t[0]), abs(t[1]), abs(t[2]))
    if (max(abs(t[3]), abs(t[4]), abs(t[5])) <= tiny and _is_isotropic(c_eig)):
        _coaxial_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, mt, tmp)
        return
    geometric_terms(c, t, s_fac, t, measure, False, w)
    gs = w[6]
    for i in range(6):
        for j in range(6):
            mt[i, j] = s_fac[i] * c_eig[i, j] * 0.5 * s_fac[j] + gs[i, j]
    _write_global(d_out, ip, rot, mt, tmp)


@_inner
def _f2_sorted(c, th, a, b, e, measure):
    """``f2(a, b, e)``: :func:`strain_f2` of the eigenvalues of indices a, b, e, sorted.

    The indices are sorted by eigenvalue (largest first), as :func:`strain_f2` takes them.
    """
    i0, i1, i2 = a, b, e
    if c[i0] < c[i1]:
        i0, i1 = i1, i0
    if c[i1] < c[i2]:
        i1, i2 = i2, i1
    if c[i0] < c[i1]:
        i0, i1 = i1, i0
    return strain_f2(c[i0], c[i1], c[i2], th[i0][i1], th[i1][i2], measure)


@_inner
def _coaxial_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, mt, tmp):
    """:func:`elastic_tangent` of an isotropic stiffness and a stress coaxial with C.

    T is diagonal in the eigenframe, so ``G_S`` is diagonal (normal columns ``4 T_a
    f2(a, a, a)``, shear ``2 (T_a f2(a, a, b) + T_b f2(a, b, b))``) and the eigenframe
    tangent is a 3x3 normal block plus a diagonal shear block, whose rotation to the
    global frame (symmetric) costs a third of a full 6x6 one.
    """
    th = ((0.5 * s_fac[0], 0.5 * s_fac[5], 0.5 * s_fac[4]),
          (0.5 * s_fac[5], 0.5 * s_fac[1], 0.5 * s_fac[3]),
          (0.5 * s_fac[4], 0.5 * s_fac[3], 0.5 * s_fac[2]))
    for i in range(3):
        for j in range(3):
            mt[i, j] = s_fac[i] * c_eig[i, j] * 0.5 * s_fac[j]
        mt[i, i] += 4.0 * t[i] * _f2_sorted(c, th, i, i, i, measure)
    for k in range(3, 6):
        a = _MI[k]
        b = _MJ[k]
        g = 2.0 * (t[a] * _f2_sorted(c, th, a, a, b, measure)
                   + t[b] * _f2_sorted(c, th, a, b, b, measure))
        mt[k, k] = s_fac[k] * c_eig[k, k] * 0.5 * s_fac[k] + g
    # tmp[:, :3] = R_N M_NN, tmp[:, 3:] = R_S diag(M_SS)
    for i in range(6):
        for b in range(3):
            tmp[i, b] = rot[i, 0] * mt[0, b] + rot[i, 1] * mt[1, b] + rot[i, 2] * mt[2, b]
        for k in range(3, 6):
            tmp[i, k] = rot[i, k] * mt[k, k]
    for i in range(6):
        for j in range(i, 6):
            s = 0.0
            for k in range(6):
                s += tmp[i, k] * rot[j, k]
            d_out[ip, 6 * i + j] = 2.0 * s
            d_out[ip, 6 * j + i] = 2.0 * s


@_inner
def _grad(sig, i, tr, c3, r, mh, vg):
    """Component ``i`` of the yield gradient along the return.

    ``dphi/dsigma_i`` (``(3 dev_i - c3 [i < 3]) / (2 r)``), minus the hardening term
    ``mu phi_pc pc'`` of the normal components and the viscous term ``vg sigma_i``.
    """
    if i < 3:
        return (3.0 * (sig[i] - tr / 3.0) - c3) / (2.0 * r) - mh - vg * sig[i]
    return 3.0 * sig[i] / (2.0 * r) - vg * sig[i]


@_inner
def foam_plastic_tangent(d_out, ip, c, t, sig, mu, evp, s_fac, k_fac, c_eig, rot, measure,
                         props, xs, ys, ds, w, mt, tmp, sysm):
    """Closed-form algorithmic tangent of a foam point after a return of size ``mu``.

    Args:
        d_out: (n, 36) tangent output.
        ip: Point index.
        c: Eigenvalues of C (3-tuple).
        t: Stress T in the eigenframe after the return (Mandel 6-tuple).
        sig: Rotated Cauchy stress in the eigenframe (Mandel 6-tuple).
        mu: Return size.
        evp: New volumetric plastic strain.
        s_fac: S-scalings ``2 theta`` (Mandel 6-tuple).
        k_fac: Sigma-scalings ``kappa`` (Mandel 6-tuple).
        c_eig: (6, 6) elastic stiffness in the eigenframe.
        rot: (6, 6) Mandel rotation of the eigenframe.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: Foam parameters (``PROP_ALPHA``, ``PROP_PT``, ``PROP_VISC``).
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        w: Scratch of :func:`geometric_terms`.
        mt: (6, 6) scratch.
        tmp: (6, 6) scratch.
        sysm: (7, 13) scratch: the linearised local system and its six right-hand sides.

    Returns:
        False if the local system is singular (the tangent is left unset).
    """
    alpha = props[PROP_ALPHA]
    pt = props[PROP_PT]
    visc = props[PROP_VISC]
    geometric_terms(c, t, s_fac, sig, measure, True, w)
    gs = w[6]
    gk = w[7]
    pc, dpc = hermite_eval(evp, xs, ys, ds)
    tr = sig[0] + sig[1] + sig[2]
    p, p0, r = _yield_radius(sig, pc, pt, alpha)
    phi_pc = -0.5 * alpha * alpha * (p - p0) / r - 0.5 * alpha
    g = math.sqrt(1.5 * _dot6(sig, sig))
    v23 = visc * 2.0 / 3.0
    hard = phi_pc * dpc
    # a = dphi/dsigma along the return (hardening and viscous parts included)
    c3 = (2.0 / 3.0) * alpha * alpha * (p - p0)
    vg = v23 * mu * 1.5 / g if (visc > 0.0 and g > 0.0) else 0.0
    mh = mu * hard
    avec = (_grad(sig, 0, tr, c3, r, mh, vg), _grad(sig, 1, tr, c3, r, mh, vg),
            _grad(sig, 2, tr, c3, r, mh, vg), _grad(sig, 3, tr, c3, r, mh, vg),
            _grad(sig, 4, tr, c3, r, mh, vg), _grad(sig, 5, tr, c3, r, mh, vg))
    b = -hard * tr - v23 * g
    for i in range(6):
        cs = 0.0
        for j in range(6):
            sysm[i, j] = mu * c_eig[i, j] * k_fac[j] + (1.0 if i == j else 0.0)
            cs += c_eig[i, j] * sig[j]
        sysm[i, 6] = cs
        sysm[6, i] = avec[i] * k_fac[i]
    sysm[6, 6] = b
    for n in range(6):
        theta_n = 0.5 * s_fac[n]
        ag = 0.0
        for i in range(6):
            cg = 0.0
            for j in range(6):
                cg += c_eig[i, j] * gk[j, n]
            sysm[i, 7 + n] = c_eig[i, n] * theta_n - mu * cg
            ag += avec[i] * gk[i, n]
        sysm[6, 7 + n] = -ag
    if not _solve_multi(sysm, 7, 6):
        return False
    for i in range(6):
        for j in range(6):
            mt[i, j] = s_fac[i] * sysm[i, 7 + j] + gs[i, j]
    _write_global(d_out, ip, rot, mt, tmp)
    return True
