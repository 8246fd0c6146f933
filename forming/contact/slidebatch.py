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

from forming.contact.slidekernels import pair_residual, project_quad
from forming.contact.tributary import spread


@numba.njit(cache=True)
def pair_all(xs, xm, facets, rings, facet, xi, inside, inside_bound):
    """Walk every slave node to the nearest facet of its pair's one-ring (in place)."""
    for i in range(xs.shape[0]):
        x = xs[i]
        f0 = facet[i]
        best, best_d, bxi, beta, ok = f0, np.inf, 0.0, 0.0, False
        for f in rings[f0]:
            if f < 0:
                break
            X = xm[facets[f]]
            from_xi = xi[i, 0] if f == f0 else 0.0
            from_eta = xi[i, 1] if f == f0 else 0.0
            a, b = project_quad(x, X, from_xi, from_eta)
            ca, cb = max(-1.0, min(1.0, a)), max(-1.0, min(1.0, b))
            d = _distance_to(x, X, ca, cb)
            if d < best_d - 1e-12:
                best, best_d, bxi, beta = f, d, a, b
                ok = abs(a) <= inside_bound and abs(b) <= inside_bound
        facet[i], xi[i, 0], xi[i, 1], inside[i] = best, bxi, beta, ok


@numba.njit(cache=True)
def _distance_to(x, X, a, b):
    N0 = 0.25 * (1 - a) * (1 - b)
    N1 = 0.25 * (1 + a) * (1 - b)
    N2 = 0.25 * (1 + a) * (1 + b)
    N3 = 0.25 * (1 - a) * (1 + b)
    d2 = 0.0
    for j in range(3):
        p = N0 * X[0, j] + N1 * X[1, j] + N2 * X[2, j] + N3 * X[3, j]
        d2 += (x[j] - p) ** 2
    return np.sqrt(d2)


@numba.njit(cache=True)
def residual_all(on, xs, xm, facets, index, s_index, facet, xi, hist, hist_xi, touched, rel,
                 lam_n, lam_t, node_normal, open_sides, area, eps, mu, s_el, kappa,
                 use_area, ptr, offsets, phi, pfacet, pxi,
                 rows, values, gap, p_new, shear, force, spring):
    """The residual of every pair ``on`` (slave node indices) as (row, value) entries.

    Returns the number of entries written into ``rows`` and ``values``; per node, the
    gap, pressure, shear, contact force and spring force are written in place.
    """
    r = np.zeros(27)
    z = np.zeros(27)
    n = 0
    for i in on:
        f, h = facet[i], hist[i]
        for j in range(3):
            z[j] = xs[i, j]
        for a in range(4):
            for j in range(3):
                z[3 + 3 * a + j] = xm[facets[f, a], j]
                z[15 + 3 * a + j] = xm[facets[h, a], j]
        g, p, sh, _c, _s, spr = pair_residual(
            z, node_normal[facets[f]], xi[i, 0], xi[i, 1], hist_xi[i, 0], hist_xi[i, 1],
            touched[i], rel[i], lam_n[i], lam_t[i], eps, mu, s_el, area[i], open_sides[f],
            kappa, r)
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
        lo, hi = ptr[i], ptr[i + 1]
        mine = np.unique(pfacet[lo:hi])
        which = np.searchsorted(mine, pfacet[lo:hi])
        K = mine.shape[0]
        Xk = np.empty((K, 4, 3))
        for k in range(K):
            for a in range(4):
                for j in range(3):
                    Xk[k, a, j] = xm[facets[mine[k], a], j]
        W = np.zeros((K, 4))
        dW = np.zeros((1, 4, 15))
        local_xi = pxi[lo:hi].copy()
        spread(xs[i], offsets[lo:hi], phi[lo:hi], which, Xk, local_xi, W, dW, False)
        for k in range(K):
            for a in range(4):
                for j in range(3):
                    rows[n] = index[facets[mine[k], a], j]
                    values[n] = W[k, a] * force[i, j]
                    n += 1
    return n
