"""Compiled element loops of the explicit solver's trilinear hexahedra.

Two passes per evaluation, around the material's point kernel:

1. :func:`right_cauchy_green` forms the deformation gradient ``F = I + sum_a u_a (x)
   g_a`` at every integration point from the nodal displacements and the reference
   shape-function gradients ``g``, and writes ``F`` and ``C = F^T F`` (row-major) and
   ``det F``;
2. :func:`nodal_forces` adds ``w P g_a`` (``P = F S``, ``S`` the second Piola-Kirchhoff
   stress the point kernel returned) to every node of the element and, for one-point
   elements, the Flanagan-Belytschko hourglass forces ``k (gamma . u) gamma``.

The loops take any number of nodes per element: the 8 of a trilinear hexahedron or
the 27 of a triquadratic one (the meso-scale cell walls).

The hourglass control is the stiffness form written in the reference configuration
(total Lagrangian): the hourglass vectors ``gamma_alpha = h_alpha - (h_alpha . X) b``
are orthogonal to every linear displacement field, so a homogeneous deformation (the
patch test) and any rigid motion, of any size, produce no hourglass force, and the
hourglass energy is the stored energy ``k |q|^2 / 2`` of the modes ``q = gamma . u``.
See docs/theory.md, section 12.
"""

from __future__ import annotations

import math

import numba

from forming.materials.kernels.curve import hermite_eval

_SQRT2 = math.sqrt(2.0)


@numba.njit(cache=True, inline="always")
def point_gradient(u, nodes, grads, c, q):
    """Deformation gradient at point ``q`` of cell ``c``, row-major as a 9-tuple."""
    f00 = f11 = f22 = 1.0
    f01 = f02 = f10 = f12 = f20 = f21 = 0.0
    for a in range(nodes.shape[1]):
        n = 3 * nodes[c, a]
        g0, g1, g2 = grads[c, q, a, 0], grads[c, q, a, 1], grads[c, q, a, 2]
        u0, u1, u2 = u[n], u[n + 1], u[n + 2]
        f00 += u0 * g0
        f01 += u0 * g1
        f02 += u0 * g2
        f10 += u1 * g0
        f11 += u1 * g1
        f12 += u1 * g2
        f20 += u2 * g0
        f21 += u2 * g1
        f22 += u2 * g2
    return f00, f01, f02, f10, f11, f12, f20, f21, f22


@numba.njit(cache=True)
def right_cauchy_green(u, nodes, grads, fm, cm, detf):
    """``F``, ``C = F^T F`` and ``det F`` at every integration point.

    Args:
        u: Nodal displacements, 3 per node (owned and ghost nodes of the rank).
        nodes: (n_cells, n_nodes) node of each element node.
        grads: (n_cells, n_q, n_nodes, 3) reference gradients of the shape functions.
        fm: (n_cells * n_q, 9) output, row-major F (:func:`nodal_forces` reads it).
        cm: (n_cells * n_q, 9) output, row-major C.
        detf: (n_cells * n_q,) output.
    """
    nc, nq = grads.shape[0], grads.shape[1]
    for c in range(nc):
        for q in range(nq):
            f00, f01, f02, f10, f11, f12, f20, f21, f22 = point_gradient(u, nodes, grads, c, q)
            p = c * nq + q
            fm[p, 0], fm[p, 1], fm[p, 2] = f00, f01, f02
            fm[p, 3], fm[p, 4], fm[p, 5] = f10, f11, f12
            fm[p, 6], fm[p, 7], fm[p, 8] = f20, f21, f22
            cm[p, 0] = f00 * f00 + f10 * f10 + f20 * f20
            cm[p, 4] = f01 * f01 + f11 * f11 + f21 * f21
            cm[p, 8] = f02 * f02 + f12 * f12 + f22 * f22
            cm[p, 1] = cm[p, 3] = f00 * f01 + f10 * f11 + f20 * f21
            cm[p, 2] = cm[p, 6] = f00 * f02 + f10 * f12 + f20 * f22
            cm[p, 5] = cm[p, 7] = f01 * f02 + f11 * f12 + f21 * f22
            detf[p] = (f00 * (f11 * f22 - f12 * f21) - f01 * (f10 * f22 - f12 * f20)
                       + f02 * (f10 * f21 - f11 * f20))


@numba.njit(cache=True)
def nodal_forces(u, nodes, grads, weights, fm, stress, gamma, k_hg, phi, hg, work, wave2, f):
    """Add the element forces to ``f``; the hourglass work; the stiffest element.

    The hourglass forces follow the modes in rate form, ``Q = Q_n + phi k (q - q_n)``,
    with ``phi`` the element's tangent over its elastic stiffness (1 while elastic), so
    that a crushing element resists its hourglass modes as a fully integrated one
    would: with its plastic tangent.

    Args:
        u: Nodal displacements, 3 per node.
        nodes: (n_cells, n_nodes) node of each element node.
        grads: (n_cells, n_q, n_nodes, 3) reference gradients of the shape functions.
        weights: (n_cells, n_q) quadrature weight times reference volume.
        fm: (n_cells * n_q, 9) deformation gradients (:func:`right_cauchy_green`'s).
        stress: (n_cells * n_q, 6) second Piola-Kirchhoff stress, Mandel.
        gamma: (n_cells, 4, 8) hourglass vectors (an empty first axis: none).
        k_hg: (n_cells, 4, 3) elastic hourglass stiffness of each mode and component
            [N/mm].
        phi: (n_cells,) tangent ratio of each element in this increment.
        hg: (4, n_cells, 4, 3) hourglass state: converged amplitudes ``q_n`` and
            forces ``Q_n``, then the new ``q`` and ``Q`` (written).
        work: (n_cells,) hourglass work of each element since ``q_n`` (written).
        wave2: Squared elastic wave speed of the material, M / rho [mm^2/s^2]; 0 skips
            the frequency bound.
        f: Nodal forces, 3 per node (added to).

    Returns:
        The largest element frequency bound omega^2 [1/s^2]:
        ``8 c^2 |F^-T g|^2`` at the element's points, the Flanagan-Belytschko bound of a
        one-point hexahedron in the current configuration (0 when ``wave2`` is 0).
    """
    nc, nq, nn = grads.shape[0], grads.shape[1], nodes.shape[1]
    omega2 = 0.0
    hourglass = gamma.shape[0] > 0
    bound = wave2 > 0.0
    for c in range(nc):
        for q in range(nq):
            g9 = fm[c * nq + q]
            f00, f01, f02, f10, f11, f12 = g9[0], g9[1], g9[2], g9[3], g9[4], g9[5]
            f20, f21, f22 = g9[6], g9[7], g9[8]
            s = stress[c * nq + q]
            s00, s11, s22 = s[0], s[1], s[2]
            s12, s02, s01 = s[3] / _SQRT2, s[4] / _SQRT2, s[5] / _SQRT2
            w = weights[c, q]
            # w P = w F S
            p00 = w * (f00 * s00 + f01 * s01 + f02 * s02)
            p01 = w * (f00 * s01 + f01 * s11 + f02 * s12)
            p02 = w * (f00 * s02 + f01 * s12 + f02 * s22)
            p10 = w * (f10 * s00 + f11 * s01 + f12 * s02)
            p11 = w * (f10 * s01 + f11 * s11 + f12 * s12)
            p12 = w * (f10 * s02 + f11 * s12 + f12 * s22)
            p20 = w * (f20 * s00 + f21 * s01 + f22 * s02)
            p21 = w * (f20 * s01 + f21 * s11 + f22 * s12)
            p22 = w * (f20 * s02 + f21 * s12 + f22 * s22)
            # cofactors of F: F^-T = cof(F) / det F (the current gradients)
            c00 = f11 * f22 - f12 * f21
            c01 = f12 * f20 - f10 * f22
            c02 = f10 * f21 - f11 * f20
            c10 = f02 * f21 - f01 * f22
            c11 = f00 * f22 - f02 * f20
            c12 = f01 * f20 - f00 * f21
            c20 = f01 * f12 - f02 * f11
            c21 = f02 * f10 - f00 * f12
            c22 = f00 * f11 - f01 * f10
            det = f00 * c00 + f01 * c01 + f02 * c02
            gg = 0.0
            for a in range(nn):
                n = 3 * nodes[c, a]
                g0, g1, g2 = grads[c, q, a, 0], grads[c, q, a, 1], grads[c, q, a, 2]
                f[n] += p00 * g0 + p01 * g1 + p02 * g2
                f[n + 1] += p10 * g0 + p11 * g1 + p12 * g2
                f[n + 2] += p20 * g0 + p21 * g1 + p22 * g2
                if bound:
                    h0 = c00 * g0 + c01 * g1 + c02 * g2
                    h1 = c10 * g0 + c11 * g1 + c12 * g2
                    h2 = c20 * g0 + c21 * g1 + c22 * g2
                    gg += h0 * h0 + h1 * h1 + h2 * h2
            if bound and det > 0.0:
                omega2 = max(omega2, 8.0 * wave2 * gg / (det * det))
        if hourglass:
            e_hg = 0.0
            for m in range(4):
                q0 = q1 = q2 = 0.0
                for a in range(8):
                    n = 3 * nodes[c, a]
                    gm = gamma[c, m, a]
                    q0 += gm * u[n]
                    q1 += gm * u[n + 1]
                    q2 += gm * u[n + 2]
                qs = (q0, q1, q2)
                for i in range(3):
                    dq = qs[i] - hg[0, c, m, i]
                    big_q = hg[1, c, m, i] + phi[c] * k_hg[c, m, i] * dq
                    e_hg += 0.5 * (hg[1, c, m, i] + big_q) * dq
                    hg[2, c, m, i] = qs[i]
                    hg[3, c, m, i] = big_q
                q0, q1, q2 = hg[3, c, m, 0], hg[3, c, m, 1], hg[3, c, m, 2]
                for a in range(8):
                    n = 3 * nodes[c, a]
                    gm = gamma[c, m, a]
                    f[n] += gm * q0
                    f[n + 1] += gm * q1
                    f[n + 2] += gm * q2
            work[c] = e_hg
    return omega2


@numba.njit(cache=True)
def tangent_ratio(ep, evp, ep_trial, evp_trial, xs, ys, ds, modulus, floor, phi):
    """Per one-point element: its tangent over its elastic stiffness in this increment.

    1 for an elastic increment; for a plastic one the series stiffness of elasticity
    and hardening, ``H / (M + H)`` with ``H = d pc / d evp`` at the new state (0 on a
    softening branch).

    Args:
        ep: (n, 6) converged plastic strain.
        evp: (n,) converged volumetric plastic strain.
        ep_trial: (n, 6) the increment's plastic strain.
        evp_trial: (n,) the increment's volumetric plastic strain.
        xs: Hardening table abscissae.
        ys: Hardening table values [MPa].
        ds: Hermite slopes of the table.
        modulus: Elastic modulus M [MPa].
        floor: Smallest ratio.
        phi: (n,) output.
    """
    for c in range(phi.shape[0]):
        change = abs(evp_trial[c] - evp[c])
        for i in range(6):
            change += abs(ep_trial[c, i] - ep[c, i])
        if change == 0.0:
            phi[c] = 1.0
            continue
        _pc, slope = hermite_eval(evp_trial[c], xs, ys, ds)
        phi[c] = max(slope / (modulus + slope) if slope > 0.0 else 0.0, floor)
