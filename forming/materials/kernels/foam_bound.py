"""Rigorous lower bound of the crushable-foam yield value along the return mapping.

The geometric bracketing of the return mapping only needs the sign of the yield
value at most of its trial return sizes. :func:`_phi_bound_data` gathers, once per
stress update, the norms a lower bound needs; :func:`_phi_surely_positive` then
proves the value positive where it is far from zero, which skips the linear solve.
"""

from __future__ import annotations

import math

from .common import _inner


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
    :func:`~.foam._rm_phi_slope` would return a positive value.

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
