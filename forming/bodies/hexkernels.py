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

The hourglass control is the stiffness form with the reference configuration's
hourglass vectors ``gamma_alpha = h_alpha - (h_alpha . X) b``, orthogonal to every
linear displacement field, so a homogeneous deformation (the patch test) and any rigid
motion, of any size, produce no hourglass force. The mode amplitudes are measured in
the element's rotated frame, ``q = R^T (gamma . u)`` with ``R`` the polar factor of
the element's mean deformation gradient, and their forces turned back, ``f_a = gamma_a
R Q`` (corotational): a bent element turned through a large angle keeps its bending in
its bending mode instead of loading another component's. The hourglass energy is the
work of ``Q`` on ``q``. See docs/theory.md, section 12.
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


@numba.njit(cache=True, inline="always")
def cofactors(a00, a01, a02, a10, a11, a12, a20, a21, a22):
    """The cofactor matrix of a 3 x 3 matrix (row-major 9-tuple): ``A^-T det A``."""
    return (a11 * a22 - a12 * a21, a12 * a20 - a10 * a22, a10 * a21 - a11 * a20,
            a02 * a21 - a01 * a22, a00 * a22 - a02 * a20, a01 * a20 - a00 * a21,
            a01 * a12 - a02 * a11, a02 * a10 - a00 * a12, a00 * a11 - a01 * a10)


@numba.njit(cache=True, inline="always")
def polar_rotation(a00, a01, a02, a10, a11, a12, a20, a21, a22):
    """The rotation R of the polar decomposition F = R U (Higham's iteration).

    ``R <- (R + R^-T) / 2`` from ``R = F``; quadratic convergence, to 1e-12 in a few
    iterations for the stretches of a crushing core. Row-major 9-tuple.
    """
    for _ in range(30):
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = cofactors(
            a00, a01, a02, a10, a11, a12, a20, a21, a22)
        h = 0.5 / (a00 * c00 + a01 * c01 + a02 * c02)  # R^-T = cof(R) / det R
        b00, b01, b02 = 0.5 * a00 + h * c00, 0.5 * a01 + h * c01, 0.5 * a02 + h * c02
        b10, b11, b12 = 0.5 * a10 + h * c10, 0.5 * a11 + h * c11, 0.5 * a12 + h * c12
        b20, b21, b22 = 0.5 * a20 + h * c20, 0.5 * a21 + h * c21, 0.5 * a22 + h * c22
        change = (abs(b00 - a00) + abs(b01 - a01) + abs(b02 - a02) + abs(b10 - a10)
                  + abs(b11 - a11) + abs(b12 - a12) + abs(b20 - a20) + abs(b21 - a21)
                  + abs(b22 - a22))
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = b00, b01, b02, b10, b11, b12, b20, b21, b22
        if change < 1e-13:
            break
    return a00, a01, a02, a10, a11, a12, a20, a21, a22


@numba.njit(cache=True, inline="always")
def element_rotation(fm, weights, c):
    """The polar rotation of element ``c``'s volume-mean deformation gradient."""
    nq = weights.shape[1]
    m0 = m1 = m2 = m3 = m4 = m5 = m6 = m7 = m8 = vol = 0.0
    for q in range(nq):
        w = weights[c, q]
        g9 = fm[c * nq + q]
        m0 += w * g9[0]
        m1 += w * g9[1]
        m2 += w * g9[2]
        m3 += w * g9[3]
        m4 += w * g9[4]
        m5 += w * g9[5]
        m6 += w * g9[6]
        m7 += w * g9[7]
        m8 += w * g9[8]
        vol += w
    return polar_rotation(m0 / vol, m1 / vol, m2 / vol, m3 / vol, m4 / vol, m5 / vol,
                          m6 / vol, m7 / vol, m8 / vol)


@numba.njit(cache=True)
def nodal_forces(u, nodes, grads, weights, fm, stress, gamma, k_hg, phi, hg, work, wave2, f):
    """Add the element forces to ``f``; the hourglass work; the stiffest element.

    The hourglass forces follow the modes in rate form, ``Q = Q_n + phi k (q - q_n)``,
    with ``phi`` the element's tangent over its elastic stiffness (1 while elastic), so
    that a crushing element resists its hourglass modes as a fully integrated one
    would: with its plastic tangent. ``q`` and ``Q`` are in the element's rotated
    frame (:func:`polar_rotation` of its volume-mean F).

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
        hg: (4, n_cells, 4, 3) hourglass state in the elements' rotated frames:
            converged amplitudes ``q_n`` and forces ``Q_n``, then the new ``q`` and
            ``Q`` (written).
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
            c00, c01, c02, c10, c11, c12, c20, c21, c22 = cofactors(
                f00, f01, f02, f10, f11, f12, f20, f21, f22)
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
            # the element's rotation (polar factor of its mean F): the modes are measured
            # and resisted in the element's rotated frame, so that a bent element turned
            # through a large angle does not load another mode's stiffness
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = element_rotation(fm, weights, c)
            e_hg = 0.0
            for m in range(4):
                g0 = g1 = g2 = 0.0
                for a in range(8):
                    n = 3 * nodes[c, a]
                    gm = gamma[c, m, a]
                    g0 += gm * u[n]
                    g1 += gm * u[n + 1]
                    g2 += gm * u[n + 2]
                # R^T q: the amplitudes in the element's frame
                qs = (r00 * g0 + r10 * g1 + r20 * g2, r01 * g0 + r11 * g1 + r21 * g2,
                      r02 * g0 + r12 * g1 + r22 * g2)
                for i in range(3):
                    dq = qs[i] - hg[0, c, m, i]
                    big_q = hg[1, c, m, i] + phi[c] * k_hg[c, m, i] * dq
                    e_hg += 0.5 * (hg[1, c, m, i] + big_q) * dq
                    hg[2, c, m, i] = qs[i]
                    hg[3, c, m, i] = big_q
                l0, l1, l2 = hg[3, c, m, 0], hg[3, c, m, 1], hg[3, c, m, 2]
                q0 = r00 * l0 + r01 * l1 + r02 * l2  # R Q: back to the global frame
                q1 = r10 * l0 + r11 * l1 + r12 * l2
                q2 = r20 * l0 + r21 * l1 + r22 * l2
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
