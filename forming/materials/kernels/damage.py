"""Damage of an isotropic elastic solid, regularised by the crack band (numba driver).

The stress is the Hencky-elastic one with damage on its tensile part only (the spectral
split of Miehe, Welschinger and Hofacker 2010, :func:`_split`): a cracked wall still
carries compression, so its elements do not collapse when a fold closes. Damage grows
with ``kappa``, the largest value reached of the largest principal stress of the
undamaged solid over E (a Rankine criterion: ``kappa`` is the strain in uniaxial
tension, and a wall's Poisson expansion under compression does not count): zero up to
the fracture strain ``eps_f``, then linear softening of the equivalent stress ``E kappa
(1 - d)`` down to zero at ``eps_u``, scaled by ``d_max`` (the residual stiffness ``1 -
d_max`` keeps the implicit system regular). Optionally a point whose band is spent
(``kappa >= eps_u``) is eroded from the next step on, as an explicit code deletes a
failed element: it carries no stress, and its shape is no longer checked (a spent point
stretched several times its length would otherwise invert its element and stop the run).
A deletion strain (optional) erodes a point the same way once its largest principal
Hencky strain in magnitude reaches it, in compression as in tension: an explicit code's
element deletion at a failure strain, as the paper's dummy materials (Table 3).

Viscous regularisation (optional, as Abaqus/Standard's for damage): the damage of a step
is ``d_n + r (d(kappa) - d_n)`` with ``r = w / (1 + w)``, ``w`` the step's travel over a
viscosity length; ``r = 1`` is rate-independent. A crack that would run at a fixed
platen position (a snap-back of the structure) then opens over a short travel instead,
which an implicit solver can follow.

Crack band (Bazant and Oh 1983): ``eps_u = 2 G_f / (sigma_f h)`` so that a band of
width ``h`` dissipates the fracture energy ``G_f`` per unit crack area whatever the
element size. ``h`` is the element's chord through its centre along the principal
direction in which damage starts (Oliver 1989), fixed at that moment: with ``g^i``
the rows of the inverse Jacobian of the cell (reference cell ``[0, 1]^3``),
``h = 1 / max_i |g^i . n|``.

History per point (the body's state arrays): ``kappa`` in the scalar slot; in the
6-vector the damage ``d``, the band ``h`` (0 before onset), the energy dissipated per
unit reference volume ``int Y dd`` (trapezoidal rule over the steps) and the energy
release rate ``Y = psi+`` of the last state (the undamaged tensile energy density), and
1 once the point is eroded.
"""

from __future__ import annotations

import numba

from .closed import elastic_tangent
from .common import STATUS_INVERTED, STATUS_OK, _inner
from .drivers import _batch_eigen, _new_tangent_work, _new_work
from .mandel import _ZERO6, SQRT2, _axpy6, _mandel_rotation_into, _mul6, _mv6
from .strain import _kinematics, strain_theta

DAMAGE_EPS_F = 0  # props: fracture strain (onset of damage)
DAMAGE_SIGMA_F = 1  # props: equivalent stress at onset, E eps_f [MPa]
DAMAGE_GF = 2  # props: fracture energy G_f [N/mm]
DAMAGE_DMAX = 3  # props: largest damage
DAMAGE_ERODE = 4  # props: 1 erodes a point whose band is spent, 0 keeps it
DAMAGE_RATE = 5  # props: share of the gap to the rate-independent damage closed this step
DAMAGE_DELETE = 6  # props: deletion strain (largest principal strain in magnitude; 0: none)
N_DAMAGE_PROPS = 7


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
def _split(e, lam, mu, d):
    """Stress of the spectral split and its eigenframe stiffness (Miehe et al. 2010).

    ``T_a = (1 - d)(lam <tr e>+ + 2 mu <e_a>+) + lam <tr e>- + 2 mu <e_a>-``: damage
    acts on the tensile part only, so a cracked wall still carries compression (and its
    elements do not collapse under it).

    Returns:
        (T, T+ (the part damage acts on), Y = psi+, the stiffness's normal weights of
        the trace and of each principal strain).
    """
    tr = e[0] + e[1] + e[2]
    w_tr = 1.0 - d if tr > 0.0 else 1.0
    wa = (1.0 - d if e[0] > 0.0 else 1.0, 1.0 - d if e[1] > 0.0 else 1.0,
          1.0 - d if e[2] > 0.0 else 1.0)
    trp = max(tr, 0.0)
    ep0, ep1, ep2 = max(e[0], 0.0), max(e[1], 0.0), max(e[2], 0.0)
    tp = (lam * trp + 2.0 * mu * ep0, lam * trp + 2.0 * mu * ep1, lam * trp + 2.0 * mu * ep2)
    t = (lam * w_tr * tr + 2.0 * mu * wa[0] * e[0], lam * w_tr * tr + 2.0 * mu * wa[1] * e[1],
         lam * w_tr * tr + 2.0 * mu * wa[2] * e[2])
    y = 0.5 * lam * trp * trp + mu * (ep0 * ep0 + ep1 * ep1 + ep2 * ep2)
    return t, tp, y, w_tr, wa


@_inner
def _shear(ta, tb, ea, eb, wa, wb, mu):
    """Eigenframe shear stiffness of pair (a, b): ``(T_a - T_b) / (e_a - e_b)``."""
    if abs(ea - eb) > 1e-10:
        return (ta - tb) / (ea - eb)
    return mu * (wa + wb)


@_inner
def _damage_points(cmats, hist_n, kappa_n, cel, measure, props, ginv, per_cell, s_out,
                   d_out, hist_out, kappa_out, want_tangent, work, twork):
    """Body of :func:`damage_points`, with its scratch arrays."""
    cs, ms, qs, active, turn, rcs, rot, _cr, c_eig, _lu, _s, _ok = work
    geo, mt, tmp, _sys = twork
    eps_f, d_max, rate = props[DAMAGE_EPS_F], props[DAMAGE_DMAX], props[DAMAGE_RATE]
    erode = props[DAMAGE_ERODE] > 0.0
    delete = props[DAMAGE_DELETE]
    lam, mu = cel[0, 1], 0.5 * cel[3, 3]  # isotropic
    young = mu * (3.0 * lam + 2.0 * mu) / (lam + mu)
    nbad = 0
    for ip in range(cmats.shape[0]):
        k, c = _batch_eigen(cmats, ip, cs, ms, qs, active, turn, rcs)
        if hist_n[ip, 4] > 0.0:  # eroded: carries nothing, whatever its shape
            for i in range(6):
                s_out[ip, i] = 0.0
                hist_out[ip, i] = hist_n[ip, i]
            kappa_out[ip] = kappa_n[ip]
            if want_tangent:
                for j in range(36):
                    d_out[ip, j] = 0.0
            continue
        ok, e, s_fac, _kf = _kinematics(c, measure, False)
        if not ok:
            nbad += 1
            continue
        q = qs[k]
        # Rankine criterion: the largest principal stress of the undamaged solid over E
        tr = e[0] + e[1] + e[2]
        a = 0
        if e[1] > e[a]:
            a = 1
        if e[2] > e[a]:
            a = 2
        e1 = (lam * tr + 2.0 * mu * e[a]) / young
        h = hist_n[ip, 1]
        if h == 0.0 and e1 > eps_f:  # damage starts now: fix the band's width
            h = _chord(ginv, ip // per_cell, q, a)
        kappa = max(kappa_n[ip], e1)
        d, slope, eps_u = 0.0, 0.0, 0.0
        if h > 0.0:
            eps_u = band_ultimate_strain(h, props)
            d, slope = softening_law(kappa, eps_f, eps_u, d_max)
        # viscous regularisation (Duvaut-Lions, backward Euler): the damage closes the
        # share ``rate`` of its gap to the rate-independent value in this step
        d = hist_n[ip, 0] + rate * (d - hist_n[ip, 0])
        slope *= rate
        t3, tp3, y, w_tr, wa = _split(e, lam, mu, d)
        t = (t3[0], t3[1], t3[2], 0.0, 0.0, 0.0)
        _mandel_rotation_into(q, rot)
        s = _mv6(rot, _mul6(s_fac, t))
        for i in range(6):
            s_out[ip, i] = s[i]
            hist_out[ip, i] = 0.0
        hist_out[ip, 0] = d
        hist_out[ip, 1] = h
        # dissipation: Y dd by the trapezoidal rule over the steps
        hist_out[ip, 2] = hist_n[ip, 2] + 0.5 * (hist_n[ip, 3] + y) * (d - hist_n[ip, 0])
        hist_out[ip, 3] = y
        spent = h > 0.0 and kappa >= eps_u and d >= 0.99 * d_max
        # deletion at a failure strain, in compression as in tension
        failed = delete > 0.0 and max(abs(e[0]), abs(e[1]), abs(e[2])) >= delete
        hist_out[ip, 4] = 1.0 if (erode and spent) or failed else 0.0
        kappa_out[ip] = kappa
        if not want_tangent:
            continue
        for i in range(6):
            for j in range(6):
                c_eig[i, j] = 0.0
        for i in range(3):
            for j in range(3):
                c_eig[i, j] = lam * w_tr
            c_eig[i, i] += 2.0 * mu * wa[i]
        # Mandel shear components (1, 2), (0, 2), (0, 1)
        c_eig[3, 3] = _shear(t3[1], t3[2], e[1], e[2], wa[1], wa[2], mu)
        c_eig[4, 4] = _shear(t3[0], t3[2], e[0], e[2], wa[0], wa[2], mu)
        c_eig[5, 5] = _shear(t3[0], t3[1], e[0], e[1], wa[0], wa[1], mu)
        elastic_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, geo, mt, tmp)
        if slope > 0.0 and e1 > kappa_n[ip]:  # loading on the softening branch
            sp = _mv6(rot, _mul6(s_fac, (tp3[0], tp3[1], tp3[2], 0.0, 0.0, 0.0)))
            # d kappa / dE_GL = sum_b (lam + 2 mu delta_ab) / E 2 theta_b N_b (x) N_b
            g = _ZERO6
            for b in range(3):
                wb = ((lam + (2.0 * mu if b == a else 0.0)) / young
                      * 2.0 * strain_theta(c[b], c[b], measure) * slope)
                nb = (q[0, b] * q[0, b], q[1, b] * q[1, b], q[2, b] * q[2, b],
                      SQRT2 * q[1, b] * q[2, b], SQRT2 * q[0, b] * q[2, b],
                      SQRT2 * q[0, b] * q[1, b])
                g = _axpy6(g, wb, nb)
            for i in range(6):
                for j in range(6):
                    d_out[ip, 6 * i + j] -= sp[i] * g[j]
    return nbad, STATUS_INVERTED if nbad else STATUS_OK


@numba.njit(cache=True)
def damage_points(cmats, hist_n, kappa_n, cel, measure, props, ginv, per_cell, s_out, d_out,
                  hist_out, kappa_out, want_tangent):
    """Stress, closed-form tangent and trial history of the damaging elastic solid.

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        hist_n: (n, 6) converged history ``[d, h, dissipated, Y, eroded, 0]``.
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
