"""Finite sliding's residual for every pair at once (numba): one call per evaluation.

The per-pair kernels (:mod:`forming.contact.slidekernels`, :mod:`.tributary`) called from
a compiled loop over the slave nodes in contact, writing the global rows and values of
the whole residual into flat arrays that PETSc takes in one ``setValues`` call. What a
Python loop over the pairs cost (some 50 us per node, most of an explicit increment) is
gone; the numbers are those of the pair kernels, unchanged.
"""

from __future__ import annotations

import numba
import numpy as np

from forming.contact.slidekernels import pair_jacobian, pair_residual, shape, shape_tuple
from forming.contact.slidesurface import ring_step
from forming.contact.tributary import spread


@numba.njit(cache=True)
def pair_all(xs, xm, facets, rings, facet, xi, inside, inside_bound):
    """Walk every slave node to the nearest facet of its pair's one-ring (in place)."""
    for i in range(xs.shape[0]):
        f, a, b = ring_step(xs[i], facet[i], xi[i, 0], xi[i, 1], facets, xm, rings)
        facet[i], xi[i, 0], xi[i, 1] = f, a, b
        inside[i] = abs(a) <= inside_bound and abs(b) <= inside_bound


@numba.njit(cache=True)
def _gather(i, xs, xm, facets, index, s_index, facet, hist, z, idx):
    """Pair ``i``'s 27 dof positions and global indices: slave, facet, history facet."""
    f, h = facet[i], hist[i]
    for j in range(3):
        z[j] = xs[i, j]
        idx[j] = s_index[i, j]
    for a in range(4):
        for j in range(3):
            z[3 + 3 * a + j] = xm[facets[f, a], j]
            z[15 + 3 * a + j] = xm[facets[h, a], j]
            idx[3 + 3 * a + j] = index[facets[f, a], j]
            idx[15 + 3 * a + j] = index[facets[h, a], j]


@numba.njit(cache=True)
def _weights(i, xs, xm, facets, ptr, offsets, phi, pfacet, pxi, derivative):
    """The master facets node ``i``'s points reach, and its weights on them (spread)."""
    lo, hi = ptr[i], ptr[i + 1]
    mine = np.unique(pfacet[lo:hi])
    which = np.searchsorted(mine, pfacet[lo:hi])
    nk = mine.shape[0]
    Xk = np.empty((nk, 4, 3))
    for q in range(nk):
        for a in range(4):
            for j in range(3):
                Xk[q, a, j] = xm[facets[mine[q], a], j]
    W = np.zeros((nk, 4))
    dW = np.zeros((nk if derivative else 1, 4, 15))
    local_xi = pxi[lo:hi].copy()
    spread(xs[i], offsets[lo:hi], phi[lo:hi], which, Xk, local_xi, W, dW, derivative)
    return mine, W, dW


@numba.njit(cache=True)
def residual_all(on, xs, xm, facets, index, s_index, facet, xi, hist, hist_xi, touched, rel,
                 lam_n, lam_t, node_normal, open_sides, area, eps, mu, s_el, kappa, width,
                 use_area, ptr, offsets, phi, pfacet, pxi,
                 rows, values, gap, p_new, shear, force, spring):
    """The residual of every pair ``on`` (slave node indices) as (row, value) entries.

    Returns the number of entries written into ``rows`` and ``values``; per node, the
    gap, pressure, shear, contact force and spring force are written in place.
    """
    r = np.zeros(27)
    z = np.zeros(27)
    idx = np.empty(27, dtype=np.int64)
    n = 0
    for i in on:
        f, h = facet[i], hist[i]
        _gather(i, xs, xm, facets, index, s_index, facet, hist, z, idx)
        g, p, sh, _c, _s, spr = pair_residual(
            z, node_normal[facets[f]], xi[i, 0], xi[i, 1], hist_xi[i, 0], hist_xi[i, 1],
            touched[i], rel[i], lam_n[i], lam_t[i], eps, mu, s_el, area[i], open_sides[f],
            kappa, width, r)
        gap[i], p_new[i] = g, p
        for j in range(3):
            shear[i, j] = sh[j]
            spring[i, j] = spr[j]
            force[i, j] = -r[j] - spr[j]
            rows[n] = s_index[i, j]
            values[n] = r[j]
            n += 1
        for a in range(4):  # the history facet: the spring's reaction (zero without)
            for j in range(3):
                rows[n] = index[facets[h, a], j]
                values[n] = r[15 + 3 * a + j]
                n += 1
        if not use_area:
            for a in range(4):
                for j in range(3):
                    rows[n] = index[facets[f, a], j]
                    values[n] = r[3 + 3 * a + j]
                    n += 1
            continue
        mine, W, _dW = _weights(i, xs, xm, facets, ptr, offsets, phi, pfacet, pxi, False)
        K = mine.shape[0]
        for k in range(K):
            for a in range(4):
                for j in range(3):
                    rows[n] = index[facets[mine[k], a], j]
                    values[n] = W[k, a] * force[i, j]
                    n += 1
    return n


@numba.njit(cache=True)
def distinct_facets(on, ptr, pfacet):
    """How many master facets the points of each pair ``on`` lie on (0 without points)."""
    out = np.zeros(on.shape[0], dtype=np.int64)
    for k in range(on.shape[0]):
        i = on[k]
        if ptr.shape[0] > i + 1 and ptr[i + 1] > ptr[i]:
            out[k] = np.unique(pfacet[ptr[i]:ptr[i + 1]]).shape[0]
    return out


@numba.njit(cache=True)
def jacobian_blocks(nk, row_at, col_at, val_at, use_area):
    """The blocks :func:`jacobian_all` writes, for :func:`forming.petscblocks.add_blocks`.

    One row per block: first row, rows, first column, columns, first value. Node to
    point: one 27 x 27 block per pair; area transfer: 15 x 27, then 12 x 39 per facet.
    """
    n = nk.shape[0] + (np.sum(nk) if use_area else 0)
    out = np.empty((n, 5), dtype=np.int64)
    j = 0
    for k in range(nk.shape[0]):
        r, c, v = row_at[k], col_at[k], val_at[k]
        if not use_area:
            out[j] = (r, 27, c, 27, v)
            j += 1
            continue
        out[j] = (r, 15, c, 27, v)
        j += 1
        for q in range(nk[k]):
            out[j] = (r + 15 + 12 * q, 12, c + 27 + 39 * q, 39, v + 405 + 468 * q)
            j += 1
    return out


@numba.njit(cache=True)
def jacobian_all(on, xs, xm, facets, index, s_index, facet, xi, hist, hist_xi, touched, rel,
                 lam_n, lam_t, node_normal, open_sides, area, eps, mu, s_el, kappa, width,
                 use_area, ptr, offsets, phi, pfacet, pxi, row_at, col_at, val_at,
                 rows, cols, values):
    """Each pair's Jacobian as dense blocks: their rows, columns and row-major values.

    Pair ``k`` writes from ``row_at[k]``, ``col_at[k]`` and ``val_at[k]``. Node to point:
    one 27 x 27 block, the derivative of
    :func:`~forming.contact.slidekernels.pair_residual`. Area transfer: a 15 x 27 block
    (the slave's and the history facet's rows on the pair's 27 dofs), then one 12 x 39
    block per master facet the points reach (its rows ``W d(force) + force dW``, see
    :func:`~forming.contact.tributary.spread`, on the 27 dofs and its own 12).
    """
    K27 = np.zeros((27, 27))
    r = np.zeros(27)
    z = np.zeros(27)
    idx = np.empty(27, dtype=np.int64)
    for k in range(on.shape[0]):
        i = on[k]
        f = facet[i]
        _gather(i, xs, xm, facets, index, s_index, facet, hist, z, idx)
        nn = node_normal[facets[f]]
        pair_jacobian(z, nn, xi[i, 0], xi[i, 1], hist_xi[i, 0], hist_xi[i, 1], touched[i],
                      rel[i], lam_n[i], lam_t[i], eps, mu, s_el, area[i], open_sides[f],
                      kappa, width, K27)
        r0, c0, v0 = row_at[k], col_at[k], val_at[k]
        if not use_area:
            for a in range(27):
                rows[r0 + a] = idx[a]
                cols[c0 + a] = idx[a]
                for b in range(27):
                    values[v0 + 27 * a + b] = K27[a, b]
            continue
        _g, _p, _s, _c, _sl, spr = pair_residual(
            z, nn, xi[i, 0], xi[i, 1], hist_xi[i, 0], hist_xi[i, 1], touched[i], rel[i],
            lam_n[i], lam_t[i], eps, mu, s_el, area[i], open_sides[f], kappa, width, r)
        t = np.empty(3)
        for j in range(3):
            t[j] = -r[j] - spr[j]
        # the contact force's derivative: the slave rows without the spring's
        dforce = np.empty((3, 27))
        for j in range(3):
            for b in range(27):
                dforce[j, b] = -K27[j, b]
        if kappa > 0.0:
            ka = kappa * area[i]
            Nh = shape(hist_xi[i, 0], hist_xi[i, 1])
            for j in range(3):
                dforce[j, j] -= -ka
                for a in range(4):
                    dforce[j, 15 + 3 * a + j] -= ka * Nh[a]
        mine, W, dW = _weights(i, xs, xm, facets, ptr, offsets, phi, pfacet, pxi, True)
        nk = mine.shape[0]
        # blocks: the slave and history rows (15) on the pair's 27 dofs; then per facet
        # its 12 rows on the 27 dofs and its own 12 (no zeros inserted elsewhere)
        for a in range(3):
            rows[r0 + a] = idx[a]
        for a in range(12):
            rows[r0 + 3 + a] = idx[15 + a]
        for b in range(27):
            cols[c0 + b] = idx[b]
        for a in range(3):
            for b in range(27):
                values[v0 + 27 * a + b] = K27[a, b]
        for a in range(12):
            for b in range(27):
                values[v0 + 27 * (3 + a) + b] = K27[15 + a, b]
        for q in range(nk):
            rq, cq, vq = r0 + 15 + 12 * q, c0 + 27 + 39 * q, v0 + 405 + 468 * q
            for b in range(27):
                cols[cq + b] = idx[b]
            for a in range(4):
                for j in range(3):
                    g = index[facets[mine[q], a], j]
                    rows[rq + 3 * a + j] = g
                    cols[cq + 27 + 3 * a + j] = g
            for a in range(4):
                for j in range(3):
                    base = vq + 39 * (3 * a + j)
                    for b in range(27):
                        values[base + b] = W[q, a] * dforce[j, b]
                    for c in range(3):  # the weights move with the node
                        values[base + c] += t[j] * dW[q, a, c]
                    for c in range(12):  # and with the facet's nodes
                        values[base + 27 + c] = t[j] * dW[q, a, 3 + c]


@numba.njit(cache=True)
def damped_trial(on, facets, facet, xi, node_normal, v_master, v_slave, nodes, gap,
                 coefficient, out):
    """Subtract ``c dg/dt`` from ``out`` (the normal multipliers) at the pairs ``on``.

    ``dg/dt = (v_s - v_m) . n``, with the master's velocity ``v_master`` (n, 3) and the
    smoothed normal interpolated at the paired point, at the pairs that penetrated at the
    last evaluation (``gap < 0``): an approaching node is not pushed before it touches.
    ``v_slave`` is the slave body's velocity (n, 3), row ``nodes[i]`` for pair ``i``.
    """
    for k in range(on.size):
        i = on[k]
        if not gap[i] < 0.0:
            continue
        w = shape_tuple(xi[i, 0], xi[i, 1])
        n0 = n1 = n2 = m0 = m1 = m2 = 0.0
        for a in range(4):
            node = facets[facet[i], a]
            n0 += w[a] * node_normal[node, 0]
            n1 += w[a] * node_normal[node, 1]
            n2 += w[a] * node_normal[node, 2]
            m0 += w[a] * v_master[node, 0]
            m1 += w[a] * v_master[node, 1]
            m2 += w[a] * v_master[node, 2]
        size = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        s = nodes[i]
        rate = ((v_slave[s, 0] - m0) * (n0 / size) + (v_slave[s, 1] - m1) * (n1 / size)
                + (v_slave[s, 2] - m2) * (n2 / size))
        out[i] -= coefficient[i] * rate

