"""Compiled node-by-node tool contact for the explicit solver's increments.

:class:`~forming.contact.nodal.NodalContact` evaluates a tool's penalty contact and
Coulomb friction at a region's owned nodes once per increment. Written as NumPy
expressions over the region, its cost is a few dozen array operations per tool and
increment whatever the region's size: on the 20 x 20 x 4 hemisphere with holder it
was about a fifth of an increment, serial, and it did not divide over the ranks. This
module is the same evaluation as one loop over the nodes, for the analytic shapes of
:mod:`forming.contact.shapes`, with their distance written once more for a single
point (:func:`distance`, dispatched on the shape's code of
:meth:`~forming.contact.shapes.AnalyticShape.kernel_code`) and the normal by the same
one-sided difference. Surface-mesh tools keep the NumPy path.
"""

from __future__ import annotations

import math

import numba
import numpy as np

PLANE, PUNCH, ROLLER, BOX, ANNULAR = range(5)

_EPS2 = 1e-12  # as forming.contact.shapes
_H = 1e-6  # difference step of the normal [mm], as forming.contact.shapes
_TINY = 1e-30
_SLACK = 1e-12  # stick test slack [MPa], as forming.contact.nodal


@numba.njit(cache=True, inline="always")
def _norm3(a, b, c):
    return math.sqrt(a * a + b * b + c * c + _EPS2)


@numba.njit(cache=True)
def distance(kind, q, x, y, z):
    """Signed distance of the point (x, y, z) to the shape ``(kind, q)``.

    The parameters ``q`` are those of ``AnalyticShape.kernel_code``; the formulas are
    the shapes' own (:mod:`forming.contact.shapes`).
    """
    if kind == PLANE:  # unit normal, point
        return q[0] * (x - q[3]) + q[1] * (y - q[4]) + q[2] * (z - q[5])
    if kind == PUNCH:  # tip, radius, length, s = -direction
        s = q[5]
        zc = q[2] + s * q[3]
        t = min(max(s * (z - zc), 0.0), q[4])
        return _norm3(x - q[0], y - q[1], z - (zc + s * t)) - q[3]
    if kind == ROLLER:  # a point on the axis (x, z), radius
        return _norm3(x - q[0], 0.0, z - q[1]) - q[2]
    if kind == BOX:  # centre, half sizes, radius
        r = q[6]
        qx = max(x - q[0], q[0] - x) - (q[3] - r)
        qy = max(y - q[1], q[1] - y) - (q[4] - r)
        qz = max(z - q[2], q[2] - z) - (q[5] - r)
        outside = _norm3(max(qx, 0.0), max(qy, 0.0), max(qz, 0.0))
        inside = min(max(qx, max(qy, qz)), 0.0)
        return outside + inside - r
    # ANNULAR: centre, hole radius, edge radius, side, thickness
    r = q[4]
    rho = math.sqrt((x - q[0]) ** 2 + (y - q[1]) ** 2 + _EPS2)
    depth = q[5] * (z - q[2])
    a = rho - (q[3] + r)
    b = depth - r
    c = (q[6] - r) - depth
    m = min(b, c)
    outside = math.sqrt(max(-a, 0.0) ** 2 + max(-m, 0.0) ** 2 + _EPS2)
    inside = min(max(-a, -m), 0.0)
    return outside + inside - r


@numba.njit(cache=True, inline="always")
def _gap_normal(kind, q, x, y, z):
    """Signed distance and outward normal (one-sided difference, as the shapes') at a point."""
    d = distance(kind, q, x, y, z)
    g0 = (distance(kind, q, x + _H, y, z) - d) / _H
    g1 = (distance(kind, q, x, y + _H, z) - d) / _H
    g2 = (distance(kind, q, x, y, z + _H) - d) / _H
    size = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2 + _TINY)
    return d, g0 / size, g1 / size, g2 / size


@numba.njit(cache=True)
def contact_residual(kind, q, u, nodes, coords, area, offset, penalty, friction,
                     damp, v, tool_velocity, lam_t, u_prev, offset_prev, shear, r, r_old,
                     f_all):
    """Penalty contact and Coulomb friction at every node; adds the residual to ``f_all``.

    The same evaluation as :meth:`forming.contact.nodal.NodalContact.residual`.

    Args:
        kind: The shape's code.
        q: The shape's parameters.
        u: The body's displacement array (3 per node).
        nodes: The region's owned nodes (block indices).
        coords: (n, 3) their reference coordinates.
        area: (n,) their reference areas [mm^2].
        offset: The tool's displacement [mm].
        penalty: Normal penalty [N/mm^3] (also the stick stiffness).
        friction: Coulomb coefficient (0: no tangential terms).
        damp: (n,) normal damping [MPa s/mm] (empty: none).
        v: The body's velocity array (with ``damp``).
        tool_velocity: The tool's velocity over the increment [mm/s] (with ``damp``).
        lam_t: (n, 3) converged shear traction.
        u_prev: (n, 3) displacement at the last commit.
        offset_prev: The tool's displacement at the last commit.
        shear: (n, 3) output: the shear traction.
        r: (n, 3) output: the residual at the nodes (its old value goes to ``r_old``).
        r_old: (n, 3) output: the previous residual.
        f_all: The body's residual array: ``r`` is added at the nodes' entries.
    """
    damped = damp.shape[0] > 0
    for i in range(nodes.shape[0]):
        k = 3 * nodes[i]
        u0, u1, u2 = u[k], u[k + 1], u[k + 2]
        x = coords[i, 0] + u0 - offset[0]
        y = coords[i, 1] + u1 - offset[1]
        z = coords[i, 2] + u2 - offset[2]
        d, n0, n1, n2 = _gap_normal(kind, q, x, y, z)
        trial = -penalty * d
        if damped and d < 0.0:
            trial -= damp[i] * ((v[k] - tool_velocity[0]) * n0 + (v[k + 1] - tool_velocity[1])
                                * n1 + (v[k + 2] - tool_velocity[2]) * n2)
        p = max(trial, 0.0)
        t0, t1, t2 = p * n0, p * n1, p * n2
        if friction > 0.0:
            s0 = u0 - u_prev[i, 0] - (offset[0] - offset_prev[0])
            s1 = u1 - u_prev[i, 1] - (offset[1] - offset_prev[1])
            s2 = u2 - u_prev[i, 2] - (offset[2] - offset_prev[2])
            sn = s0 * n0 + s1 * n1 + s2 * n2
            ln = lam_t[i, 0] * n0 + lam_t[i, 1] * n1 + lam_t[i, 2] * n2
            a0 = lam_t[i, 0] - ln * n0 - penalty * (s0 - sn * n0)
            a1 = lam_t[i, 1] - ln * n1 - penalty * (s1 - sn * n1)
            a2 = lam_t[i, 2] - ln * n2 - penalty * (s2 - sn * n2)
            norm = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2 + _TINY)
            limit = friction * p
            scale = 1.0 if norm <= limit + _SLACK else limit / norm
            shear[i, 0], shear[i, 1], shear[i, 2] = a0 * scale, a1 * scale, a2 * scale
            t0 += shear[i, 0]
            t1 += shear[i, 1]
            t2 += shear[i, 2]
        w = -area[i]
        r_old[i, 0], r_old[i, 1], r_old[i, 2] = r[i, 0], r[i, 1], r[i, 2]
        r[i, 0], r[i, 1], r[i, 2] = w * t0, w * t1, w * t2
        f_all[k] += r[i, 0]
        f_all[k + 1] += r[i, 1]
        f_all[k + 2] += r[i, 2]


@numba.njit(cache=True)
def commit_slip(u, nodes, shear, lam_t, u_prev):
    """The increment accepted: the shear becomes history, slip is measured from here."""
    for i in range(nodes.shape[0]):
        k = 3 * nodes[i]
        for j in range(3):
            lam_t[i, j] = shear[i, j]
            u_prev[i, j] = u[k + j]


NO_DAMPING = (np.zeros(0), np.zeros(0), np.zeros(3))
"""Arguments ``damp, v, tool_velocity`` of an undamped :func:`contact_residual`."""
