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
def shape_tuple(xi, eta):
    """Bilinear shape functions at (xi, eta), nodes (-1,-1), (1,-1), (1,1), (-1,1).

    A tuple (no array: for the per-pair kernels); :func:`shape` is the array.
    """
    return (0.25 * (1 - xi) * (1 - eta), 0.25 * (1 + xi) * (1 - eta),
            0.25 * (1 + xi) * (1 + eta), 0.25 * (1 - xi) * (1 + eta))


@numba.njit(cache=True)
def shape(xi, eta):
    """:func:`shape_tuple` as an array."""
    return np.array(shape_tuple(xi, eta))


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
    # X(xi, eta) = c0 + xi c1 + eta c2 + xi eta c3, one scalar per component
    c0x = 0.25 * (X[0, 0] + X[1, 0] + X[2, 0] + X[3, 0])
    c0y = 0.25 * (X[0, 1] + X[1, 1] + X[2, 1] + X[3, 1])
    c0z = 0.25 * (X[0, 2] + X[1, 2] + X[2, 2] + X[3, 2])
    c1x = 0.25 * (-X[0, 0] + X[1, 0] + X[2, 0] - X[3, 0])
    c1y = 0.25 * (-X[0, 1] + X[1, 1] + X[2, 1] - X[3, 1])
    c1z = 0.25 * (-X[0, 2] + X[1, 2] + X[2, 2] - X[3, 2])
    c2x = 0.25 * (-X[0, 0] - X[1, 0] + X[2, 0] + X[3, 0])
    c2y = 0.25 * (-X[0, 1] - X[1, 1] + X[2, 1] + X[3, 1])
    c2z = 0.25 * (-X[0, 2] - X[1, 2] + X[2, 2] + X[3, 2])
    c3x = 0.25 * (X[0, 0] - X[1, 0] + X[2, 0] - X[3, 0])
    c3y = 0.25 * (X[0, 1] - X[1, 1] + X[2, 1] - X[3, 1])
    c3z = 0.25 * (X[0, 2] - X[1, 2] + X[2, 2] - X[3, 2])
    xi, eta = xi0, eta0
    for _it in range(25):
        t1x, t1y, t1z = c1x + eta * c3x, c1y + eta * c3y, c1z + eta * c3z
        t2x, t2y, t2z = c2x + xi * c3x, c2y + xi * c3y, c2z + xi * c3z
        rx = x[0] - (c0x + xi * c1x + eta * c2x + xi * eta * c3x)
        ry = x[1] - (c0y + xi * c1y + eta * c2y + xi * eta * c3y)
        rz = x[2] - (c0z + xi * c1z + eta * c2z + xi * eta * c3z)
        # the sums in the order of a loop over the components (from zero)
        f1 = 0.0 + rx * t1x + ry * t1y + rz * t1z
        f2 = 0.0 + rx * t2x + ry * t2y + rz * t2z
        rt12 = 0.0 + rx * c3x + ry * c3y + rz * c3z
        a11 = 0.0 + t1x * t1x + t1y * t1y + t1z * t1z
        a22 = 0.0 + t2x * t2x + t2y * t2y + t2z * t2z
        a12 = 0.0 + t1x * t2x + t1y * t2y + t1z * t2z
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
def _point(X, N):
    """The facet point ``sum_a N_a X_a``, summed as :func:`frame` sums it."""
    px, py, pz = 0.0, 0.0, 0.0
    for a in range(4):
        px += N[a] * X[a, 0]
        py += N[a] * X[a, 1]
        pz += N[a] * X[a, 2]
    return px, py, pz


@numba.njit(cache=True)
def _pair(z, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu, s_el, area,
          open_sides, kappa, width, out, mode_p, mode_t, extra):
    """:func:`pair_residual` without temporary arrays: shear and spring into ``extra``.

    ``extra`` (6,): the shear traction, then the spring's force. Returns the gap, the
    pressure and the two decisions. The arithmetic is :func:`pair_residual`'s, operation
    for operation (the results are the same to the bit).
    """
    x0, x1, x2 = z[0], z[1], z[2]
    X = z[3:15].reshape(4, 3)
    H = z[15:27].reshape(4, 3)
    xi, eta = project_quad(z[0:3], X, xi0, eta0)
    N = shape_tuple(xi, eta)
    pm0, pm1, pm2 = _point(X, N)
    # the smoothed normal: nodal normals interpolated, normalised
    n0, n1, n2 = 0.0, 0.0, 0.0
    for a in range(4):
        n0 += N[a] * nn[a, 0]
        n1 += N[a] * nn[a, 1]
        n2 += N[a] * nn[a, 2]
    size_n = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    n0, n1, n2 = n0 / size_n, n1 / size_n, n2 / size_n
    g = (x0 - pm0) * n0 + (x1 - pm1) * n1 + (x2 - pm2) * n2
    trial_p = lam_n - eps * g
    edge = -0.5 * width if width > 0.0 else -eps * TOUCH
    closed = trial_p >= edge if mode_p < 0 else mode_p == 1
    p = ramp(trial_p, width) if closed else 0.0
    s0, s1, s2 = 0.0, 0.0, 0.0
    slipping = False
    Nh = shape_tuple(hxi, heta)
    if mu > 0.0 and closed:
        limit = mu * p
        d = lam_t[0] * n0 + lam_t[1] * n1 + lam_t[2] * n2
        tr0, tr1, tr2 = lam_t[0] - d * n0, lam_t[1] - d * n1, lam_t[2] - d * n2
        if has_hist:
            sl0, sl1, sl2 = x0 - rel[0], x1 - rel[1], x2 - rel[2]
            for a in range(4):
                sl0 -= Nh[a] * H[a, 0]
                sl1 -= Nh[a] * H[a, 1]
                sl2 -= Nh[a] * H[a, 2]
            ds = sl0 * n0 + sl1 * n1 + sl2 * n2
            sl0, sl1, sl2 = sl0 - ds * n0, sl1 - ds * n1, sl2 - ds * n2
            # elastic slip: stiffness mu p / s_el; s_el = 0: the penalty eps (explicit runs)
            c = limit / s_el if s_el > 0.0 else eps
            tr0, tr1, tr2 = tr0 - c * sl0, tr1 - c * sl1, tr2 - c * sl2
        size = math.sqrt(tr0 ** 2 + tr1 ** 2 + tr2 ** 2 + 1e-30)
        slipping = size > limit + 1e-12 if mode_t < 0 else mode_t == 1
        if slipping:
            f = limit / size
            s0, s1, s2 = f * tr0, f * tr1, f * tr2
        else:
            s0, s1, s2 = tr0, tr1, tr2
    t0, t1, t2 = p * n0 + s0, p * n1 + s1, p * n2 + s2
    # past an edge of the master surface (not an edge shared with another facet) a node
    # sliding off the master lets go gradually, not at once
    beyond = max(open_sides[0] * (-1.0 - xi), open_sides[1] * (xi - 1.0),
                 open_sides[2] * (-1.0 - eta), open_sides[3] * (eta - 1.0))
    share = area * max(0.0, 1.0 - beyond / FADE) if beyond > 0.0 else area
    sp0, sp1, sp2 = 0.0, 0.0, 0.0
    if kappa > 0.0:
        sp0, sp1, sp2 = rel[0] - x0, rel[1] - x1, rel[2] - x2
        for a in range(4):
            sp0 += Nh[a] * H[a, 0]
            sp1 += Nh[a] * H[a, 1]
            sp2 += Nh[a] * H[a, 2]
        ka = kappa * area
        sp0, sp1, sp2 = sp0 * ka, sp1 * ka, sp2 * ka
    t = (t0, t1, t2)
    sp = (sp0, sp1, sp2)
    for j in range(3):
        out[j] = -share * t[j] - sp[j]
        for a in range(4):
            out[3 + 3 * a + j] = share * N[a] * t[j]
        for a in range(4):
            out[15 + 3 * a + j] = Nh[a] * sp[j]
    extra[0], extra[1], extra[2] = s0, s1, s2
    extra[3], extra[4], extra[5] = sp0, sp1, sp2
    return g, p, closed, slipping


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
    extra = np.empty(6)
    g, p, closed, slipping = _pair(z, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n,
                                   lam_t, eps, mu, s_el, area, open_sides, kappa, width, out,
                                   mode_p, mode_t, extra)
    return g, p, extra[:3].copy(), closed, slipping, extra[3:].copy()


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
    extra = np.empty(6)
    _g, _p, closed, slipping = _pair(zp, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n,
                                     lam_t, eps, mu, s_el, area, open_sides, kappa, width,
                                     rp, -1, -1, extra)
    mode_p, mode_t = int(closed), int(slipping)
    for k in range(27):
        zk = zp[k]
        zp[k] = zk + _H
        _pair(zp, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu, s_el, area,
              open_sides, kappa, width, rp, mode_p, mode_t, extra)
        zp[k] = zk - _H
        _pair(zp, nn, xi0, eta0, hxi, heta, has_hist, rel, lam_n, lam_t, eps, mu, s_el, area,
              open_sides, kappa, width, rm, mode_p, mode_t, extra)
        zp[k] = zk
        for i in range(27):
            out[i, k] = (rp[i] - rm[i]) / (2.0 * _H)
