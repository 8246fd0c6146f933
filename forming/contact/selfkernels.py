"""Compiled contact test and forces of a surface in contact with itself (folding walls).

The surface is a set of triangles over surface nodes (:mod:`.selfcontact` builds it from
a body's boundary faces); every surface node is a slave of every triangle that is not
on a cell the node belongs to (the walls' own faces are never their own obstacle). A
node has penetrated a triangle when its distance to the triangle's plane along the
outward normal is negative but shallower than the search depth, and its projection
falls inside the triangle: deeper points are taken to be the other side of the node's
own wall, which is at least a wall thickness behind it. The triangles each node is
tested against come from a Verlet list (:mod:`.selflist`).
"""

from __future__ import annotations

import numba
import numpy as np

_BARY_SLACK = 1e-9  # barycentric slack of a projection inside a triangle
_LATERAL = 0.5  # lateral reach beyond a triangle's edges, a fraction of the search depth
_KEEP_DEG = 30.0  # a slave keeps its force on a new triangle facing within this angle
_KEEP_COS = float(np.cos(np.radians(_KEEP_DEG)))
# farthest a node registers a contact with a triangle, in search depths: a depth off
# its plane and the lateral reach off its edges
HIT_RADIUS = float(np.sqrt(1.0 + _LATERAL**2))


@numba.njit(cache=True, inline="always")
def _clamp(la, lb, lc):
    """Barycentric coordinates moved onto the triangle (an approximate nearest point)."""
    la, lb, lc = max(la, 0.0), max(lb, 0.0), max(lc, 0.0)
    total = la + lb + lc
    return la / total, lb / total, lc / total


@numba.njit(cache=True)
def _frames(x, tris):
    """Per triangle: unit normal, the two edges from its first node, and its doubled area.

    Computed once per search for every triangle (each is a candidate of tens of slave
    nodes); a degenerate triangle has area 0 and no normal.
    """
    out = np.zeros((tris.shape[0], 10))
    for t in range(tris.shape[0]):
        n0, n1, n2 = tris[t, 0], tris[t, 1], tris[t, 2]
        e10 = x[n1, 0] - x[n0, 0]
        e11 = x[n1, 1] - x[n0, 1]
        e12 = x[n1, 2] - x[n0, 2]
        e20 = x[n2, 0] - x[n0, 0]
        e21 = x[n2, 1] - x[n0, 1]
        e22 = x[n2, 2] - x[n0, 2]
        m0 = e11 * e22 - e12 * e21
        m1 = e12 * e20 - e10 * e22
        m2 = e10 * e21 - e11 * e20
        size = np.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        if size > 0.0:
            out[t, 0], out[t, 1], out[t, 2] = m0 / size, m1 / size, m2 / size
        out[t, 3], out[t, 4], out[t, 5] = e10, e11, e12
        out[t, 6], out[t, 7], out[t, 8] = e20, e21, e22
        out[t, 9] = size
    return out


@numba.njit(cache=True)
def penetrations(x, tris, slaves, offsets, cand, depth, both_sides, touching, onset):
    """The deepest candidate triangle each slave node has penetrated.

    Args:
        x: (n, 3) current node coordinates [mm].
        tris: (n_t, 3) triangles, outward normal by the right-hand rule.
        slaves: Indices of the nodes to test.
        offsets: (n_s + 1,) offsets into ``cand`` per slave (:func:`candidates`).
        cand: Candidate triangles.
        depth: Search depth [mm].
        both_sides: Also report nodes within ``depth`` in front of a triangle (the
            proximity check of solvers that do not enforce the contact).
        touching: (n_s,) whether each slave was in contact at the last evaluation.
        onset: Deepest penetration at which a slave not touching before may start a
            contact [mm]: a node found deep behind a face it was never in front of is on
            the wrong side of a fold or a junction, not in contact.

    Returns:
        (triangle or -1, signed distance [mm], barycentric coordinates (n_s, 3), unit
        normal (n_s, 3)) per slave.
    """
    n_s = slaves.shape[0]
    hit = np.full(n_s, -1, dtype=np.int64)
    dist = np.zeros(n_s)
    bary = np.zeros((n_s, 3))
    normal = np.zeros((n_s, 3))
    frame = _frames(x, tris)
    for i in range(n_s):
        s = slaves[i]
        p0, p1, p2 = x[s, 0], x[s, 1], x[s, 2]
        best = depth
        deepest = depth if touching[i] else onset
        for r in range(offsets[i], offsets[i + 1]):
            t = cand[r]
            g = frame[t]
            if g[9] == 0.0:  # a degenerate triangle
                continue
            m0, m1, m2 = g[0], g[1], g[2]
            n0 = tris[t, 0]
            w0, w1, w2 = p0 - x[n0, 0], p1 - x[n0, 1], p2 - x[n0, 2]
            d = w0 * m0 + w1 * m1 + w2 * m2
            if not (-deepest < d < (depth if both_sides else 0.0)):
                continue
            if abs(d) >= best:
                continue
            e10, e11, e12, e20, e21, e22 = g[3], g[4], g[5], g[6], g[7], g[8]
            # barycentric coordinates of the projection
            q0, q1, q2 = w0 - d * m0, w1 - d * m1, w2 - d * m2
            d00 = e10 * e10 + e11 * e11 + e12 * e12
            d01 = e10 * e20 + e11 * e21 + e12 * e22
            d11 = e20 * e20 + e21 * e21 + e22 * e22
            d20 = q0 * e10 + q1 * e11 + q2 * e12
            d21 = q0 * e20 + q1 * e21 + q2 * e22
            den = d00 * d11 - d01 * d01
            lb = (d11 * d20 - d01 * d21) / den
            lc = (d00 * d21 - d01 * d20) / den
            la = 1.0 - lb - lc
            if min(la, lb, lc) < -_BARY_SLACK:
                # outside: the nearest point of the triangle, if the node lies within the
                # lateral reach of it (a vertex or an edge of a warped face, where no
                # triangle holds the projection)
                la, lb, lc = _clamp(la, lb, lc)
                o0 = q0 - (lb * e10 + lc * e20)
                o1 = q1 - (lb * e11 + lc * e21)
                o2 = q2 - (lb * e12 + lc * e22)
                if o0 * o0 + o1 * o1 + o2 * o2 > (_LATERAL * depth) ** 2:
                    continue
            best = abs(d)
            hit[i] = t
            dist[i] = d
            bary[i, 0], bary[i, 1], bary[i, 2] = la, lb, lc
            normal[i, 0], normal[i, 1], normal[i, 2] = m0, m1, m2
    return hit, dist, bary, normal


@numba.njit(cache=True, inline="always")
def _facing(x, tris, t, n):
    """Cosine between triangle ``t``'s unit normal at ``x`` and the unit vector ``n``."""
    a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
    e10, e11, e12 = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    e20, e21, e22 = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
    m0 = e11 * e22 - e12 * e21
    m1 = e12 * e20 - e10 * e22
    m2 = e10 * e21 - e11 * e20
    size = np.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    if size == 0.0:
        return -1.0
    return (m0 * n[0] + m1 * n[1] + m2 * n[2]) / size


@numba.njit(cache=True)
def pair_shares(slaves, hit, dist, bary, tris, share):
    """Add to ``share`` how many pairs pull on each node.

    A slave counts 1, a triangle's node its barycentric weight; summed over ranks, it
    divides the pairs' penalties (:func:`penalty_residual`).
    """
    for i in range(slaves.shape[0]):
        t = hit[i]
        if t < 0 or dist[i] >= 0.0:
            continue
        share[slaves[i]] += 1.0
        for a in range(3):
            share[tris[t, a]] += bary[i, a]


@numba.njit(cache=True)
def penalty_residual(x, slaves, hit, dist, bary, normal, tris, mass, vel, share, scale,
                     damping, dt, state, r):
    """Add the penalty forces of the penetrated slaves to the residual ``r``.

    The penalty of a pair is ``k = scale m / dt^2``, ``m`` the pair's reduced mass
    (``1/m = 1/m_s + sum_a lambda_a^2 / m_a``, the mass its normal motion moves): the
    soft-constraint penalty of explicit codes, which cannot shorten the stable time step
    for ``scale`` well below 1; it is divided by the largest number of pairs that share a
    node of the pair (a master node under several slaves would otherwise sum their
    penalties past the stable limit).

    The elastic normal force is updated in rate form, ``f += k (d_old - d)`` on the same
    triangle, and capped by ``k (-d)``: a penalty that grows while a pair is penetrated
    (another pair leaves a shared node, the reduced mass or the time step changes) then
    adds no energy, which the total form ``k (-d)`` did (the contact's work turned
    negative and the walls inverted). A pair starts unloaded: only the penetration gained
    after it was found pushes (the initial-penetration rule of explicit codes), and a
    slave that moves to another triangle keeps its force only if that triangle faces
    within ``_KEEP_DEG`` of the last one; otherwise it starts again from zero. Both
    starts used to take the force of the whole penetration, or of the last triangle along
    a new normal (across a fold, or between two walls that overlap): each such start
    added energy, and in ``meso_crushing`` the pairs had put 61 N mm into the walls by
    1.9 mm of stroke, until nodes flew off at 300 m/s. A viscous force ``c w``,
    ``c = 2 damping sqrt(k m)``, on the normal approach velocity ``w`` damps the pair's
    ringing; the normal force never pulls.

    Args:
        x: (n, 3) current node coordinates [mm].
        slaves: Slave node indices.
        hit: Their triangle or -1 (:func:`penetrations`).
        dist: Signed distances [mm].
        bary: Barycentric coordinates of the projections.
        normal: Unit outward normals of the triangles.
        tris: (n_t, 3) triangles.
        mass: (n,) lumped nodal masses [t].
        vel: (n, 3) nodal velocities [mm/s].
        share: (n,) pairs pulling on each node (:func:`pair_shares`, over all ranks).
        scale: Penalty over ``m / dt^2``.
        damping: Fraction of the pair's critical damping.
        dt: Time step [s].
        state: (n_s, 3) per slave: the triangle of the last evaluation (-1: none), its
            elastic normal force [N] and signed distance [mm]; updated.
        r: (n, 3) residual (internal minus external forces), added to.

    Returns:
        (pairs in contact, deepest penetration [mm]).
    """
    count = 0
    deepest = 0.0
    for i in range(slaves.shape[0]):
        t = hit[i]
        if t < 0 or dist[i] >= 0.0:
            state[i, 0], state[i, 1], state[i, 2] = -1.0, 0.0, 0.0
            continue
        s = slaves[i]
        most = max(share[s], 1.0)
        for a in range(3):
            if bary[i, a] > 0.0:
                most = max(most, share[tris[t, a]])
        inv = 1.0 / mass[s]  # the pair's reduced mass along the normal
        for a in range(3):
            inv += bary[i, a] ** 2 / mass[tris[t, a]]
        m = 1.0 / inv
        k = scale * m / (dt * dt * most)
        last = int(state[i, 0])
        if last == t:
            elastic = state[i, 1] + k * (state[i, 2] - dist[i])
        elif last >= 0 and _facing(x, tris, last, normal[i]) >= _KEEP_COS:
            elastic = state[i, 1]
        else:
            elastic = 0.0
        elastic = min(max(elastic, 0.0), -k * dist[i])
        state[i, 0], state[i, 1], state[i, 2] = t, elastic, dist[i]
        w = 0.0  # approach velocity: the slave's along -n relative to the face's point
        for c in range(3):
            rel = vel[s, c]
            for a in range(3):
                rel -= bary[i, a] * vel[tris[t, a], c]
            w -= rel * normal[i, c]
        fn = max(elastic + 2.0 * damping * np.sqrt(k * m) * w, 0.0)
        for c in range(3):
            r[s, c] -= fn * normal[i, c]
            for a in range(3):
                r[tris[t, a], c] += bary[i, a] * fn * normal[i, c]
        deepest = max(deepest, -dist[i])
        count += 1
    return count, deepest
