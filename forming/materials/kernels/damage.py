"""Isotropic damage of an elastic solid, regularised by the crack band (numba driver).

The stress is ``S = (1 - d) S0(C)`` with ``S0`` the elastic stress of
:mod:`.elastic`. Damage grows with the largest principal strain reached,
``kappa = max over the history of f(c_max)`` (a Rankine-type, tension-only
criterion): zero up to the fracture strain ``eps_f``, then linear softening of the
equivalent stress ``E kappa (1 - d)`` down to zero at ``eps_u``, scaled by ``d_max``
(the residual stiffness ``1 - d_max`` keeps the implicit system regular, where an
explicit code would delete the element).

Crack band (Bazant and Oh 1983): ``eps_u = 2 G_f / (sigma_f h)`` so that a band of
width ``h`` dissipates the fracture energy ``G_f`` per unit crack area whatever the
element size. ``h`` is the element's chord through its centre along the principal
direction in which damage starts (Oliver 1989), fixed at that moment: with ``g^i``
the rows of the inverse Jacobian of the cell (reference cell ``[0, 1]^3``),
``h = 1 / max_i |g^i . n|``.

History per point (the body's state arrays): ``kappa`` in the scalar slot; in the
6-vector the damage ``d``, the band ``h`` (0 before onset), the energy dissipated per
unit reference volume ``int Y dd`` (trapezoidal rule over the steps) and the energy
release rate ``Y = psi0`` of the last state (the undamaged strain energy density).
"""

from __future__ import annotations

import numba

from .closed import elastic_tangent
from .common import STATUS_INVERTED, STATUS_OK, _inner
from .drivers import _batch_eigen, _new_tangent_work, _new_work
from .elastic import _elastic_state
from .mandel import SQRT2, _mul6, _mv6
from .strain import strain_f, strain_theta

DAMAGE_EPS_F = 0  # props: fracture strain (onset of damage)
DAMAGE_SIGMA_F = 1  # props: equivalent stress at onset, E eps_f [MPa]
DAMAGE_GF = 2  # props: fracture energy G_f [N/mm]
DAMAGE_DMAX = 3  # props: largest damage
N_DAMAGE_PROPS = 4


@_inner
def softening_law(kappa, eps_f, eps_u, d_max):
    """Damage and its slope for the largest equivalent strain reached ``kappa``.

    ``d = d_max (1 - eps_f (eps_u - kappa) / (kappa (eps_u - eps_f)))`` between
    ``eps_f`` and ``eps_u``: linear softening scaled by ``d_max``, so that the whole
    softening branch is followed and a point dissipates ``d_max`` times the triangle
    under its equivalent stress-strain curve (capping ``d`` instead would cut off the
    tail: 6% of the energy at ``d_max = 0.99`` and ``eps_u = 6 eps_f``).

    Returns:
        (d, dd/dkappa); the slope is 0 outside the softening branch.
    """
    if kappa <= eps_f:
        return 0.0, 0.0
    if kappa >= eps_u:
        return d_max, 0.0
    d = 1.0 - eps_f * (eps_u - kappa) / (kappa * (eps_u - eps_f))
    return d_max * d, d_max * eps_f * eps_u / ((eps_u - eps_f) * kappa * kappa)


@_inner
def band_ultimate_strain(h, props):
    """``eps_u`` of a band of width ``h``; just above ``eps_f`` if the band is too wide.

    A band wider than ``2 G_f / (sigma_f eps_f)`` would have to snap back; it is given
    the steepest softening instead (and dissipates more than ``G_f``: the body warns).
    """
    eps_f = props[DAMAGE_EPS_F]
    eps_u = 2.0 * props[DAMAGE_GF] / (props[DAMAGE_SIGMA_F] * h)
    return max(eps_u, 1.001 * eps_f)


@_inner
def _chord(ginv, cell, q, a):
    """The cell's chord through its centre along eigenvector ``a`` of ``q`` [mm]."""
    m = 0.0
    for i in range(3):
        s = ginv[cell, 3 * i] * q[0, a] + ginv[cell, 3 * i + 1] * q[1, a] \
            + ginv[cell, 3 * i + 2] * q[2, a]
        m = max(m, abs(s))
    return 1.0 / m


@_inner
def _damage_points(cmats, hist_n, kappa_n, cel, measure, props, ginv, per_cell, s_out,
                   d_out, hist_out, kappa_out, want_tangent, work, twork):
    """Body of :func:`damage_points`, with its scratch arrays."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, _lu, _s, _ok = work
    geo, mt, tmp, _sys = twork
    eps_f, d_max = props[DAMAGE_EPS_F], props[DAMAGE_DMAX]
    nbad = 0
    for ip in range(cmats.shape[0]):
        k, c = _batch_eigen(cmats, ip, cs, ms, qs, active, turn, rcs)
        ok, s_fac, t = _elastic_state(c, qs[k], cel, measure, rot, cr, c_eig, 6)
        if not ok:
            nbad += 1
            continue
        s0 = _mv6(rot, _mul6(s_fac, t))
        a = 0
        if c[1] > c[a]:
            a = 1
        if c[2] > c[a]:
            a = 2
        e1 = strain_f(c[a], measure)
        h = hist_n[ip, 1]
        if h == 0.0 and e1 > eps_f:  # damage starts now: fix the band's width
            h = _chord(ginv, ip // per_cell, qs[k], a)
        kappa = max(kappa_n[ip], e1)
        d, slope = 0.0, 0.0
        if h > 0.0:
            d, slope = softening_law(kappa, eps_f, band_ultimate_strain(h, props), d_max)
        # energy release rate Y = psi0 (the undamaged energy; the strain is diagonal in
        # the eigenframe); dissipation by the trapezoidal rule in d
        y = 0.5 * (t[0] * strain_f(c[0], measure) + t[1] * strain_f(c[1], measure)
                   + t[2] * strain_f(c[2], measure))
        for i in range(6):
            s_out[ip, i] = (1.0 - d) * s0[i]
            hist_out[ip, i] = 0.0
        hist_out[ip, 0] = d
        hist_out[ip, 1] = h
        hist_out[ip, 2] = hist_n[ip, 2] + 0.5 * (hist_n[ip, 3] + y) * (d - hist_n[ip, 0])
        hist_out[ip, 3] = y
        kappa_out[ip] = kappa
        if not want_tangent:
            continue
        elastic_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, geo, mt, tmp)
        for j in range(36):
            d_out[ip, j] *= 1.0 - d
        if slope > 0.0 and e1 > kappa_n[ip]:  # loading on the softening branch
            q = qs[k]
            w = 2.0 * strain_theta(c[a], c[a], measure) * slope
            g = (q[0, a] * q[0, a], q[1, a] * q[1, a], q[2, a] * q[2, a],
                 SQRT2 * q[1, a] * q[2, a], SQRT2 * q[0, a] * q[2, a],
                 SQRT2 * q[0, a] * q[1, a])
            for i in range(6):
                for j in range(6):
                    d_out[ip, 6 * i + j] -= w * s0[i] * g[j]
    return nbad, STATUS_INVERTED if nbad else STATUS_OK


@numba.njit(cache=True)
def damage_points(cmats, hist_n, kappa_n, cel, measure, props, ginv, per_cell, s_out, d_out,
                  hist_out, kappa_out, want_tangent):
    """Stress, closed-form tangent and trial history of the damaging elastic solid.

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        hist_n: (n, 6) converged history ``[d, h, dissipated, Y, 0, 0]``.
        kappa_n: (n,) converged largest equivalent strain.
        cel: (6, 6) Mandel elastic stiffness.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: ``N_DAMAGE_PROPS`` parameters (``DAMAGE_*`` indices).
        ginv: (cells, 9) inverse Jacobians at the cell centres, row-major.
        per_cell: Points per cell (point ``ip`` is in cell ``ip // per_cell``).
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (ignored unless ``want_tangent``).
        hist_out: (n, 6) trial history.
        kappa_out: (n,) trial largest equivalent strain.
        want_tangent: Whether to write ``d_out``.

    Returns:
        (number of points with a non-zero status, worst status).
    """
    return _damage_points(cmats, hist_n, kappa_n, cel, measure, props, ginv, per_cell, s_out,
                          d_out, hist_out, kappa_out, want_tangent, _new_work(),
                          _new_tangent_work())
