"""Compiled kernels of node-to-surface finite sliding (numba).

A slave node against a bilinear quadrilateral master facet (the face of a hexahedron),
both in the current configuration:

* :func:`project_quad`: the closest point's coordinates (xi, eta) on the facet's
  bilinear surface, by Newton on ``(x - X(xi)) . X,xi = 0``, unclamped (a point beyond
  the facet's edges returns coordinates beyond +/-1, so the caller can tell);
* :func:`pair_residual`: the contact's residual on the pair's 27 dofs (the slave node,
  the facet's four nodes, and the four nodes of the facet the friction history lives
  on), for the augmented-Lagrangian normal pressure and Coulomb friction with the
  elastic-slip stick law, the slip measured against the master's material point of
  the last converged step (convected coordinates: it stays right after the slave moves
  to another facet);
* :func:`pair_jacobian`: that residual's derivative by central differences on the 27
  dofs, the facet choice and the active set (open or closed, stick or slip) held at
  their values at the point (the derivative of the branch the residual is on, as a
  semi-smooth Newton takes it), consistent with the residual to about 1e-9 relative
  (in coordinates relative to the slave node, with a step of 1e-5 mm).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_H = 1e-5  # difference step of the Jacobian [mm] (well below the elastic slip, 5e-3 h)
TOUCH = 1e-9  # a gap this small [mm] counts as closed: a body laid exactly on another
# (gap 0 up to round-off, whose sign depends on the machine) is supported at once
FADE = 0.3  # beyond the master's edge a node's force fades to zero over this part of a facet
# (0.1 cycled with period 3 in the demonstrator, where a trimmed blank's top skin slides
# past the core's edge)


@numba.njit(cache=True)
def shape(xi, eta):
    """Bilinear shape functions at (xi, eta), nodes (-1,-1), (1,-1), (1,1), (-1,1)."""
    return np.array([0.25 * (1 - xi) * (1 - eta), 0.25 * (1 + xi) * (1 - eta),
                     0.25 * (1 + xi) * (1 + eta), 0.25 * (1 - xi) * (1 + eta)])


@numba.njit(cache=True)
def frame(X, xi, eta):
    """Point, tangents X,xi and X,eta, and X,xi,eta of the bilinear facet X (4, 3)."""
    N = shape(xi, eta)
    dxi = np.array([-0.25 * (1 - eta), 0.25 * (1 - eta), 0.25 * (1 + eta), -0.25 * (1 + eta)])
    deta = np.array([-0.25 * (1 - xi), -0.25 * (1 + xi), 0.25 * (1 + xi), 0.25 * (1 - xi)])
    cross = np.array([0.25, -0.25, 0.25, -0.25])
    p = np.zeros(3)
    t1 = np.zeros(3)
    t2 = np.zeros(3)
    t12 = np.zeros(3)
    for a in range(4):
        for j in range(3):
            p[j] += N[a] * X[a, j]
            t1[j] += dxi[a] * X[a, j]
            t2[j] += deta[a] * X[a, j]
            t12[j] += cross[a] * X[a, j]
    return p, t1, t2, t12


@numba.njit(cache=True)
def project_quad(x, X, xi0, eta0):
    """Coordinates of the closest point of the bilinear facet X (4, 3) to x.

    Newton from (xi0, eta0), at most 25 iterations, steps capped at 1; the result may
    lie beyond +/-1 (the point projects outside the facet). Scalar arithmetic only (no
    temporary arrays: it runs for every point at every evaluation).
    """
    # X(xi, eta) = c0 + xi c1 + eta c2 + xi eta c3
    c0 = np.empty(3)
    c1 = np.empty(3)
    c2 = np.empty(3)
    c3 = np.empty(3)
    for j in range(3):
        c0[j] = 0.25 * (X[0, j] + X[1, j] + X[2, j] + X[3, j])
        c1[j] = 0.25 * (-X[0, j] + X[1, j] + X[2, j] - X[3, j])
        c2[j] = 0.25 * (-X[0, j] - X[1, j] + X[2, j] + X[3, j])
        c3[j] = 0.25 * (X[0, j] - X[1, j] + X[2, j] - X[3, j])
    xi, eta = xi0, eta0
    for _it in range(25):
        f1 = f2 = rt12 = a11 = a22 = a12 = 0.0
        for j in range(3):
            t1 = c1[j] + eta * c3[j]
            t2 = c2[j] + xi * c3[j]
            r = x[j] - (c0[j] + xi * c1[j] + eta * c2[j] + xi * eta * c3[j])
            f1 += r * t1
            f2 += r * t2
            rt12 += r * c3[j]
            a11 += t1 * t1
            a22 += t2 * t2
            a12 += t1 * t2
        a12 -= rt12
        det = a11 * a22 - a12 * a12
        if det <= 0.0:
            break
        dxi = (a22 * f1 - a12 * f2) / det
        deta = (a11 * f2 - a12 * f1) / det
        dxi = max(-1.0, min(1.0, dxi))
        deta = max(-1.0, min(1.0, deta))
        xi += dxi
        eta += deta
        if abs(dxi) + abs(deta) < 1e-14:
            break
    return xi, eta


@numba.njit(cache=True)
def normal_gap(x, X, xi, eta):
    """Unit normal ``X,xi x X,eta``, the facet point and the gap ``n . (x - p)``."""
    p, t1, t2, _t12 = frame(X, xi, eta)
    n = np.array([t1[1] * t2[2] - t1[2] * t2[1], t1[2] * t2[0] - t1[0] * t2[2],
                  t1[0] * t2[1] - t1[1] * t2[0]])
    n /= math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    r = x - p
    return n, p, r[0] * n[0] + r[1] * n[1] + r[2] * n[2]


@numba.njit(cache=True)
def smooth_normal(nn, xi, eta):
    """The nodal normals ``nn`` (4, 3) interpolated at (xi, eta), normalised."""
    N = shape(xi, eta)
    n = np.zeros(3)
    for a in range(4):
        for j in range(3):
            n[j] += N[a] * nn[a, j]
    return n / math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])


@numba.njit(cache=True)
def ramp(trial, width):
    """The pressure for an augmented trial pressure: ``max(0, trial)``, or smoothed.

    With ``width > 0`` the kink is replaced by a parabola over ``|trial| < width / 2``
    (C1, zero below ``-width / 2``, ``trial`` above ``width / 2``; ``width / 8`` at zero):
    a node at almost zero pressure then has a pressure and a stiffness that change
    continuously from one Newton iteration to the next instead of switching.
    """
    if width <= 0.0 or trial >= 0.5 * width:
        return max(trial, 0.0)
    if trial <= -0.5 * width:
        return 0.0
    return (trial + 0.5 * width) ** 2 / (2.0 * width)


@numba.njit(cache=True)
def pair_residual(z, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu, s_el,
                  area, open_sides, kappa, width, out, mode_p=-1, mode_t=-1):
    """Residual (27,) of one slave node on its facet, for the dofs ``z`` (27,).

    ``z``: the slave's position (3), the facet's four nodes (12), the history facet's
    four nodes (12), current. ``nn``: the facet's nodal normals (4, 3), held within a
    load step, interpolated so that the normal is continuous from facet to facet. The
    facet point is projected from (xi0, eta0) (the pairing's coordinates) so the
    derivative follows the point. ``mode_p`` (-1: by the sign of the trial pressure, 0:
    open, 1: closed) and ``mode_t`` (-1: by the cone, 0: stick, 1: slip) hold the
    active set for the Jacobian's differences. ``open_sides`` (4,): 1.0 where the facet's
    side (xi = -1, xi = 1, eta = -1, eta = 1) is an edge of the master surface; a node
    beyond it by ``d`` (in facet coordinates) carries ``1 - d / FADE`` of its force.
    ``kappa`` [N/mm^3]: a stabilising spring on the slave's motion, within the step,
    relative to the master point (``H`` at ``(hxi, heta)`` plus ``rel``) it was at when the
    step began (0: none; ``has_hist`` decides friction only, the spring acts whenever
    ``kappa > 0``). ``width`` [MPa]: the pressure ramp's smoothing (0: the sharp
    ``max(0, trial)``; else :func:`ramp`). Returns the gap, the pressure, the shear
    traction, the two decisions and the spring's force on the slave (3,).
    """
    x = z[0:3]
    X = z[3:15].reshape(4, 3)
    H = z[15:27].reshape(4, 3)
    xi, eta = project_quad(x, X, xi0, eta0)
    _nf, p_m, _g = normal_gap(x, X, xi, eta)
    n = smooth_normal(nn, xi, eta)
    g = (x[0] - p_m[0]) * n[0] + (x[1] - p_m[1]) * n[1] + (x[2] - p_m[2]) * n[2]
    trial_p = lam_n - eps * g
    edge = -0.5 * width if width > 0.0 else -eps * TOUCH
    closed = trial_p >= edge if mode_p < 0 else mode_p == 1
    p = ramp(trial_p, width) if closed else 0.0
    shear = np.zeros(3)
    slipping = False
    if mu > 0.0 and closed:
        limit = mu * p
        trial = lam_t - (lam_t[0] * n[0] + lam_t[1] * n[1] + lam_t[2] * n[2]) * n
        if has_hist:
            Nh = shape(hxi, heta)
            slip = x - rel
            for a in range(4):
                slip -= Nh[a] * H[a]
            slip -= (slip[0] * n[0] + slip[1] * n[1] + slip[2] * n[2]) * n
            # elastic slip: stiffness mu p / s_el; s_el = 0: the penalty eps (explicit runs)
            trial -= (limit / s_el if s_el > 0.0 else eps) * slip
        size = math.sqrt(trial[0] ** 2 + trial[1] ** 2 + trial[2] ** 2 + 1e-30)
        slipping = size > limit + 1e-12 if mode_t < 0 else mode_t == 1
        shear = (limit / size) * trial if slipping else trial
    t = p * n + shear
    N = shape(xi, eta)
    # past an edge of the master surface (not an edge shared with another facet) a node
    # sliding off the master lets go gradually, not at once
    beyond = max(open_sides[0] * (-1.0 - xi), open_sides[1] * (xi - 1.0),
                 open_sides[2] * (-1.0 - eta), open_sides[3] * (eta - 1.0))
    share = area * max(0.0, 1.0 - beyond / FADE) if beyond > 0.0 else area
    spring = np.zeros(3)
    Nh = shape(hxi, heta)
    if kappa > 0.0:
        for j in range(3):
            spring[j] = rel[j] - x[j]
            for a in range(4):
                spring[j] += Nh[a] * H[a, j]
            spring[j] *= kappa * area
    for j in range(3):
        out[j] = -share * t[j] - spring[j]
        for a in range(4):
            out[3 + 3 * a + j] = share * N[a] * t[j]
        for a in range(4):
            out[15 + 3 * a + j] = Nh[a] * spring[j]
    return g, p, shear, closed, slipping, spring


@numba.njit(cache=True)
def pair_jacobian(z, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu, s_el,
                  area, open_sides, kappa, width, out):
    """Central-difference derivative (27, 27) of :func:`pair_residual` with respect to z.

    The positions are taken relative to the slave node (the residual depends on
    differences only), which keeps the round-off of the differences small.
    """
    zp = z.copy()
    for k in range(9):
        for j in range(3):
            zp[3 * k + j] -= z[j]
    rp = np.zeros(27)
    rm = np.zeros(27)
    _g, _p, _s, closed, slipping, _f = pair_residual(
        zp, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu, s_el, area,
        open_sides, kappa, width, rp)
    mode_p, mode_t = int(closed), int(slipping)
    for k in range(27):
        zk = zp[k]
        zp[k] = zk + _H
        pair_residual(zp, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu,
                      s_el, area, open_sides, kappa, width, rp, mode_p, mode_t)
        zp[k] = zk - _H
        pair_residual(zp, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu,
                      s_el, area, open_sides, kappa, width, rm, mode_p, mode_t)
        zp[k] = zk
        for i in range(27):
            out[i, k] = (rp[i] - rm[i]) / (2.0 * _H)
