"""Crushable-foam stress update: yield function, return mapping and the point update.

The yield function (:func:`_foam_yield`) is written in the rotated Cauchy stress;
the flow is radial in it, so for a return of size ``mu`` the stress follows from one
6x6 linear solve, and its slope from a second one (:func:`_rm_phi_slope`).
:func:`_return_newton` finds the root ``mu`` by Newton's method in a bracket;
should it fail, :func:`_return_mapping` brackets the smallest root geometrically and
closes in by Illinois regula falsi. :func:`_foam_update`
is the whole update at one point: elastic trial, yield check, return;
:func:`_foam_frozen_update` stops at the elastic trial (plastic state frozen).
"""

from __future__ import annotations

import math

from .common import STATUS_INVERTED, STATUS_OK, STATUS_RETURN_MAP, _inner
from .curve import hermite_eval
from .foam_bound import _phi_bound_data, _phi_surely_positive
from .linalg import _lu_resolve6, _lu_solve6x2
from .mandel import (
    _ZERO6,
    _axpy6,
    _dot6,
    _mandel_rotation_into,
    _mtv6,
    _mul6,
    _mv6,
    _stiffness_in_frame,
    _sub6,
)
from .strain import _kinematics

# Indices into ``props``, the foam's scalar parameters (built by
# :meth:`forming.materials.solids.CrushableFoam.kernel_data`).
PROP_ALPHA = 0  # shape factor alpha of the yield ellipse
PROP_PT = 1  # hydrostatic tension strength pt [MPa]
PROP_VISC = 2  # eta / dt of the viscous regularisation (0: rate-independent)
N_PROPS = 3


@_inner
def _yield_radius(sig, pc, pt, alpha):
    """Pressure, centre of the yield ellipse and its radius term for a stress.

    Args:
        sig: Rotated Cauchy stress (Mandel 6-tuple).
        pc: Hydrostatic compression strength.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.

    Returns:
        (p, p0, r): the pressure ``p = -tr(sigma)/3`` (positive in compression), the
        centre ``p0 = (pc - pt)/2`` and ``r = sqrt(q^2 + alpha^2 (p - p0)^2)``.
    """
    tr = sig[0] + sig[1] + sig[2]
    p = -tr / 3.0
    q2 = 0.0
    for i in range(6):
        d = sig[i] - (tr / 3.0 if i < 3 else 0.0)
        q2 += d * d
    q2 *= 1.5
    p0 = 0.5 * (pc - pt)
    return p, p0, math.sqrt(q2 + alpha * alpha * (p - p0) ** 2)


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
    _p, _p0, r = _yield_radius(sig, pc, pt, alpha)
    return r - 0.5 * alpha * (pc + pt)


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
        lu: (6, 10) scratch for the linear solves.
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
    mt_tr = _mv6(c_eig, _mul6(k_fac, t_tr))
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
        f_hi, _s, t, sig = _rm_phi_slope(mu_hi, c_eig, k_fac, t_tr, mt_tr, lu, evp_n, xs, ys,
                                         ds, pt, alpha, visc)
        hi_known = True
        if f_hi <= 0.0:
            break
    else:
        return False, mu_hi, t, sig
    if not lo_known:
        f_lo, _s, t, sig = _rm_phi_slope(mu_lo, c_eig, k_fac, t_tr, mt_tr, lu, evp_n, xs, ys,
                                         ds, pt, alpha, visc)
    side = 0
    for _it in range(200):
        mu = (mu_lo * f_hi - mu_hi * f_lo) / (f_hi - f_lo)
        if not (mu_lo < mu < mu_hi):
            mu = 0.5 * (mu_lo + mu_hi)
        fm, _s, t, sig = _rm_phi_slope(mu, c_eig, k_fac, t_tr, mt_tr, lu, evp_n, xs, ys, ds,
                                       pt, alpha, visc)
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
def _rm_phi_slope(mu, c_eig, k_fac, t_tr, mt_tr, lu, evp_n, xs, ys, ds, pt, alpha, visc):
    """Yield value after a return of size ``mu``, and its slope.

    The flow is radial in the rotated Cauchy stress (``dg m = mu sigma``), so for a
    given ``mu`` the update ``T = T_tr - mu C K T`` is linear: ``T = A^-1 T_tr`` with
    ``A = I + mu M``, ``M = C K``, ``K = diag(kappa)``. With viscous regularisation
    (``visc = eta / dt > 0``, Duvaut-Lions/Perzyna overstress) the value is
    ``f - visc * dgamma`` with ``dgamma = 2/3 mu g``, ``g = sqrt(3/2 sigma : sigma)``.
    As ``A^-1`` and ``M``
    commute, ``M T = A^-1 M T_tr`` (the second right-hand side) and ``dT/dmu = -A^-1
    M T`` (a solve with the kept factors). The slope follows by the chain rule
    through ``sigma = K T``, ``evp = evp_n - mu tr(sigma)`` and the hardening curve.

    Args:
        mu: Return size.
        c_eig: (6, 6) elastic stiffness in the eigenframe.
        k_fac: Sigma-scalings ``kappa`` (6-tuple).
        t_tr: Trial stress T (6-tuple).
        mt_tr: ``M T_tr`` (6-tuple).
        lu: (6, 10) scratch for the linear solves.
        evp_n: Converged volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.
        visc: ``eta / dt`` (no regularisation unless positive).

    Returns:
        (yield value, its slope d phi / d mu (NaN for a singular system), stress T,
        rotated Cauchy stress), the last two as 6-tuples.
    """
    if mu == 0.0:  # A = I
        t = t_tr
        dt = (-mt_tr[0], -mt_tr[1], -mt_tr[2], -mt_tr[3], -mt_tr[4], -mt_tr[5])
    else:
        for i in range(6):
            for j in range(6):
                lu[i, j] = mu * c_eig[i, j] * k_fac[j]
            lu[i, i] += 1.0
            lu[i, 6] = t_tr[i]
            lu[i, 7] = mt_tr[i]
        if not _lu_solve6x2(lu):
            return math.nan, math.nan, _ZERO6, _ZERO6
        for i in range(6):
            lu[i, 9] = -lu[i, 7]
        _lu_resolve6(lu)
        t = (lu[0, 6], lu[1, 6], lu[2, 6], lu[3, 6], lu[4, 6], lu[5, 6])
        dt = (lu[0, 9], lu[1, 9], lu[2, 9], lu[3, 9], lu[4, 9], lu[5, 9])
    sig = _mul6(k_fac, t)
    dsig = _mul6(k_fac, dt)
    tr = sig[0] + sig[1] + sig[2]
    dtr = dsig[0] + dsig[1] + dsig[2]
    evp = evp_n - mu * tr
    pc, h = hermite_eval(evp, xs, ys, ds)
    dpc = h * (-tr - mu * dtr)
    p, p0, r = _yield_radius(sig, pc, pt, alpha)
    dq2 = 0.0
    for i in range(6):
        dq2 += (sig[i] - (tr / 3.0 if i < 3 else 0.0)) * (dsig[i] - (dtr / 3.0 if i < 3 else 0.0))
    dq2 *= 3.0
    dr = 0.5 * dq2 + alpha * alpha * (p - p0) * (-dtr / 3.0 - 0.5 * dpc)
    dr = dr / r if r > 0.0 else math.nan
    f = r - 0.5 * alpha * (pc + pt)
    slope = dr - 0.5 * alpha * dpc
    if visc > 0.0:
        g = math.sqrt(1.5 * _dot6(sig, sig))
        f -= visc * (2.0 / 3.0) * mu * g
        slope -= visc * (2.0 / 3.0) * (g + (mu * 1.5 * _dot6(sig, dsig) / g if g > 0.0 else 0.0))
    return f, slope, t, sig


@_inner
def _return_newton(f_tr, tol, c_eig, k_fac, t_tr, lu, evp_n, xs, ys, ds, pt, alpha, visc):
    """Root ``mu > 0`` of ``phi(mu)`` by Newton's method, safeguarded by a bracket.

    From ``mu = 0``, where ``phi = f_tr > 0``, Newton steps (:func:`_rm_phi_slope`);
    every evaluated point narrows the bracket ``[lo, hi]`` (``phi(lo) > 0 >= phi(hi)``,
    ``hi`` infinite until a point with ``phi <= 0`` is found), and a step that leaves
    it, or a slope that is not negative, is replaced by bisection (doubling while
    ``hi`` is infinite). A small return converges in two or three solves where the
    bracketing of :func:`_return_mapping` takes several more.

    Args:
        f_tr: Trial yield value (positive).
        tol: Tolerance on ``|phi|``.
        c_eig: (6, 6) elastic stiffness in the eigenframe.
        k_fac: Sigma-scalings ``kappa`` (6-tuple).
        t_tr: Trial stress T (6-tuple).
        lu: (6, 10) scratch for the linear solves.
        evp_n: Converged volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pt: Hydrostatic tension strength.
        alpha: Shape factor of the yield ellipse.
        visc: ``eta / dt`` (no regularisation unless positive).

    Returns:
        (converged, mu, stress T, rotated Cauchy stress); not converged in 40 steps
        (the caller then brackets, :func:`_return_mapping`).
    """
    mt_tr = _mv6(c_eig, _mul6(k_fac, t_tr))
    # the slope at mu = 0 (no solve: T = T_tr, dT = -M T_tr)
    f0, slope, _t, _s = _rm_phi_slope(0.0, c_eig, k_fac, t_tr, mt_tr, lu, evp_n, xs, ys, ds,
                                      pt, alpha, visc)
    lo, hi = 0.0, math.inf
    mu = f_tr / -slope if slope < 0.0 else math.nan
    if not (mu > 0.0 and math.isfinite(mu)):
        return False, 0.0, _ZERO6, _ZERO6
    for _it in range(40):
        f, slope, t, sig = _rm_phi_slope(mu, c_eig, k_fac, t_tr, mt_tr, lu, evp_n, xs, ys, ds,
                                         pt, alpha, visc)
        if not math.isfinite(f):
            hi = mu
        elif abs(f) < tol:
            return True, mu, t, sig
        elif f > 0.0:
            lo = mu
        else:
            hi = mu
        if hi - lo < 1e-15 * hi and math.isfinite(f):
            return True, mu, t, sig
        step = mu - f / slope if slope < 0.0 and math.isfinite(f) else math.nan
        if lo < step < hi:
            mu = step
        elif math.isfinite(hi):
            mu = 0.5 * (lo + hi)
        else:
            mu = 2.0 * mu
    return False, mu, _ZERO6, _ZERO6


@_inner
def _foam_trial(c, q, ep_old, cel, measure, rot, cr, c_eig):
    """Elastic trial state of the foam at one point, about the plastic strain ``ep_old``.

    Args:
        c: Eigenvalues of C (3-tuple).
        q: (3, 3) eigenvectors of C (columns).
        ep_old: Converged plastic strain (global Mandel 6-tuple).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        rot: (6, 6) output: Mandel rotation of the eigenframe.
        cr: (6, 6) scratch.
        c_eig: (6, 6) output: stiffness in the eigenframe.

    Returns:
        (C positive definite, S-scalings, sigma-scalings, plastic strain and trial
        stress T in the eigenframe), the last four as Mandel 6-tuples (all zero, and
        ``rot``, ``c_eig`` unset, if C is not positive definite).
    """
    ok, e_eig, s_fac, k_fac = _kinematics(c, measure, True)
    if not ok:
        return False, s_fac, k_fac, _ZERO6, _ZERO6
    _mandel_rotation_into(q, rot)
    _stiffness_in_frame(rot, cel, cr, c_eig, 6)
    ep_eig = _mtv6(rot, ep_old)
    t_tr = _mv6(c_eig, _sub6(e_eig, ep_eig))
    return True, s_fac, k_fac, ep_eig, t_tr


@_inner
def _foam_return(c, q, ep_n, evp_n, pc_n, cel, measure, props, xs, ys, ds, pc_slope, rot, cr,
                 c_eig, lu):
    """Crushable-foam stress update at one point, in the eigenframe of C.

    Args:
        c: Eigenvalues of C (3-tuple).
        q: (3, 3) eigenvectors of C (columns).
        ep_n: (6,) converged plastic strain (global Mandel).
        evp_n: Converged volumetric plastic strain.
        pc_n: Compression strength at ``evp_n``.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: (N_PROPS,) parameters: ``PROP_ALPHA`` alpha, ``PROP_PT`` pt,
            ``PROP_VISC`` eta / dt (0 without viscous regularisation).
        xs: Hardening table abscissae.
        ys: Hardening table values.
        ds: Hardening table slopes.
        pc_slope: Lipschitz constant of the hardening curve.
        rot: (6, 6) output: Mandel rotation of the eigenframe.
        cr: (6, 6) scratch.
        c_eig: (6, 6) output: stiffness in the eigenframe.
        lu: (6, 10) scratch for the linear solves.

    Returns:
        (status, S-scalings, sigma-scalings, stress T, rotated Cauchy stress sigma,
        return size ``mu`` (0 for an elastic point), new plastic strain (global
        Mandel; ``ep_n`` unless converged), new volumetric plastic strain); the
        scalings, T and sigma are eigenframe Mandel 6-tuples.
    """
    ep_old = (ep_n[0], ep_n[1], ep_n[2], ep_n[3], ep_n[4], ep_n[5])
    ok, s_fac, k_fac, ep_eig, t_tr = _foam_trial(c, q, ep_old, cel, measure, rot, cr, c_eig)
    if not ok:
        return STATUS_INVERTED, s_fac, k_fac, _ZERO6, _ZERO6, 0.0, ep_old, evp_n
    alpha = props[PROP_ALPHA]
    pt = props[PROP_PT]
    visc = props[PROP_VISC]
    sig_tr = _mul6(k_fac, t_tr)
    f_tr = _foam_yield(sig_tr, pc_n, pt, alpha)
    scale = pc_n + pt
    if f_tr <= 1e-12 * scale:
        return STATUS_OK, s_fac, k_fac, t_tr, sig_tr, 0.0, ep_old, evp_n
    converged, mu, t, sig = _return_newton(f_tr, 1e-13 * scale, c_eig, k_fac, t_tr, lu, evp_n,
                                           xs, ys, ds, pt, alpha, visc)
    if not converged:
        bound = _phi_bound_data(f_tr, c_eig, k_fac, t_tr, scale, evp_n, pc_slope, alpha, visc)
        converged, mu, t, sig = _return_mapping(f_tr, 1e-13 * scale, bound, c_eig, k_fac, t_tr,
                                                lu, evp_n, xs, ys, ds, pt, alpha, visc)
    if not converged:
        return STATUS_RETURN_MAP, s_fac, k_fac, _ZERO6, _ZERO6, 0.0, ep_old, evp_n
    ep_new = _mv6(rot, _axpy6(ep_eig, mu, sig))
    evp = evp_n - mu * (sig[0] + sig[1] + sig[2])
    return STATUS_OK, s_fac, k_fac, t, sig, mu, ep_new, evp


@_inner
def _foam_update(c, q, ep_n, evp_n, pc_n, cel, measure, props, xs, ys, ds, pc_slope, rot, cr,
                 c_eig, lu):
    """Crushable-foam stress update at one point (:func:`_foam_return`, S global).

    Returns:
        (status, S, new plastic strain, new volumetric plastic strain); S (zero on
        failure) and the plastic strain (``ep_n`` unless converged) are global Mandel
        6-tuples.
    """
    st, s_fac, _k, t, _sig, _mu, ep_new, evp = _foam_return(
        c, q, ep_n, evp_n, pc_n, cel, measure, props, xs, ys, ds, pc_slope, rot, cr, c_eig, lu)
    if st != STATUS_OK:
        return st, _ZERO6, ep_new, evp
    return STATUS_OK, _mv6(rot, _mul6(s_fac, t)), ep_new, evp


@_inner
def _foam_frozen_update(c, q, ep_n, cel, measure, rot, cr, c_eig):
    """Foam stress at one point with its plastic state frozen: the elastic trial stress.

    No yield check and no return mapping: the stress of elastic unloading (or
    reloading) about the converged plastic strain ``ep_n``, which is the foam's
    stress whenever the trial state is inside the yield surface. A trial state whose
    rotated Cauchy stress is not finite fails with ``STATUS_RETURN_MAP``, as the
    return mapping it would enter in :func:`_foam_update` does.

    Args:
        c: Eigenvalues of C (3-tuple).
        q: (3, 3) eigenvectors of C (columns).
        ep_n: (6,) converged plastic strain (global Mandel).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        rot: (6, 6) output: Mandel rotation of the eigenframe.
        cr: (6, 6) scratch.
        c_eig: (6, 6) output: stiffness in the eigenframe.

    Returns:
        (status, S as a Mandel 6-tuple in the global frame (zero on failure),
        S-scalings and trial stress T in the eigenframe).
    """
    ep_old = (ep_n[0], ep_n[1], ep_n[2], ep_n[3], ep_n[4], ep_n[5])
    ok, s_fac, k_fac, _ep, t_tr = _foam_trial(c, q, ep_old, cel, measure, rot, cr, c_eig)
    if not ok:
        return STATUS_INVERTED, _ZERO6, s_fac, _ZERO6
    sig = _mul6(k_fac, t_tr)
    if not math.isfinite(_dot6(sig, sig)):
        return STATUS_RETURN_MAP, _ZERO6, s_fac, _ZERO6
    return STATUS_OK, _mv6(rot, _mul6(s_fac, t_tr)), s_fac, t_tr
