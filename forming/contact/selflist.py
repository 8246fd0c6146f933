"""The Verlet list of a surface in contact with itself: which triangles each node may touch.

Each slave node of a self-contact (:mod:`.selfcontact`) is tested, at every evaluation,
against a list of candidate triangles (:mod:`.selfkernels`). The list holds every
triangle within a reach of the node, the reach being the farthest a contact registers
(``HIT_RADIUS`` search depths) plus a margin, and it stays exact while the nodes move
less than the margin between them.

The full search (:func:`candidates`) bins the triangles on a uniform grid: each triangle
into every cell that its bounding sphere, grown by the reach, covers; the spacing
follows the median triangle, so a node finds every triangle it can touch in its own
cell, and a few stretched faces (cracked walls) neither coarsen the grid nor fill it
(one that would cover too many cells is tested against every node). A candidate is a
triangle whose nearest point lies within the reach: a bounding sphere would list a face
stretched across a crack for every node its sphere holds.

A partial search (:func:`refresh`) updates the list for a few fast nodes only (a
fragment flung off a cracked wall), and drops the triangles and nodes of eroded cells:
the lists of the fast slaves are searched afresh, and every slave is tested again
against the triangles that have a fast vertex.
"""

from __future__ import annotations

import numba
import numpy as np

_OVERSIZED = 512  # grid cells a triangle's box may cover before every node tests it
# a partial search tests, behind a bounding-box check, up to this many pairs per
# triangle and listed pair that a full search would go through: a little below where
# the two took the same time on the 3 x 3 meso patch at 0.64 strain (about 270, timed
# once on the state the run had there)
PARTIAL_COST = 200.0


class VerletList:
    """The candidate triangles of each slave node, kept exact as the nodes move.

    The list holds, for each slave, the triangles within ``hit`` (the farthest a contact
    registers) plus a margin. A pair left out cannot come within ``hit`` while each of
    its nodes has moved less than half the margin from where the pair was last
    searched. A node that has moved farther has its pairs searched again
    (:func:`refresh`, with twice the margin: the other nodes of its pairs may have moved
    up to half the margin already); if so many have that a partial search would cost
    more than a full one, the whole list is searched again (:func:`candidates`).

    Args:
        tris: (n_t, 3) triangles over the surface nodes.
        tri_cell: (n_t,) global cell of each triangle.
        ptr: (n + 1,) offsets into ``cells`` per node.
        cells: Global indices of the cells each node belongs to.
        slaves: Indices of the nodes whose candidates are listed.
        hit: The farthest a node registers a contact with a triangle [mm].
        margin: The motion the list survives [mm].
        partial_cost: A partial search's pair tests, at most, per triangle and listed pair
            (the work of a full search).
    """

    def __init__(self, tris, tri_cell, ptr, cells, slaves, hit: float, margin: float,
                 partial_cost: float = PARTIAL_COST):
        if not margin > 0.0:
            raise ValueError(f"margin must be positive, got {margin}")
        self.tris, self.tri_cell, self.ptr, self.cells = tris, tri_cell, ptr, cells
        self.slaves = slaves
        self.hit = float(hit)
        self.margin = float(margin)
        self.partial_cost = float(partial_cost)
        n = len(ptr) - 1
        self.tri_dead = np.zeros(len(tris), dtype=bool)
        self.node_dead = np.zeros(n, dtype=bool)
        self._x: np.ndarray | None = None  # where each node's pairs were last searched
        self._list = (np.zeros(slaves.size + 1, dtype=np.int64), np.zeros(0, dtype=np.int64))
        self._dropped = False  # triangles or nodes left the contact since the last update
        self.searches = [0, 0]  # full and partial searches so far

    def forget(self) -> None:
        """Search the whole list afresh at the next update."""
        self._x = None

    def erode(self, tri_dead: np.ndarray, node_dead: np.ndarray) -> None:
        """Take the triangles and nodes of eroded cells out of the contact (for good)."""
        self.tri_dead = np.asarray(tri_dead, dtype=bool)
        self.node_dead = np.asarray(node_dead, dtype=bool)
        self._dropped = True

    def update(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The list at the node coordinates ``x``: (offsets per slave, triangles)."""
        fast = None
        if self._x is not None:
            step = x - self._x
            fast = ~self.node_dead & (np.einsum("ij,ij->i", step, step)
                                      > (0.5 * self.margin) ** 2)
        if fast is None or self._partial_cost(fast) > self.partial_cost * (
                len(self.tris) + self._list[1].size):
            self._list = candidates(x, self.tris, self.tri_cell, self.ptr, self.cells,
                                    self.slaves, self.hit + self.margin, self.tri_dead,
                                    self.node_dead)
            self._x = x.copy()
            self.searches[0] += 1
        elif self._dropped or fast.any():
            self._list = refresh(x, self.tris, self.tri_cell, self.ptr, self.cells,
                                 self.slaves, *self._list, fast,
                                 self.hit + 2.0 * self.margin, self.tri_dead, self.node_dead)
            self._x[fast] = x[fast]
            self.searches[1] += 1
        self._dropped = False
        return self._list

    def _partial_cost(self, fast: np.ndarray) -> float:
        """Pair tests of a partial search for the ``fast`` nodes."""
        if not fast.any():
            return 0.0
        moved_tris = int(np.count_nonzero(fast[self.tris].any(axis=1)))
        fast_slaves = int(np.count_nonzero(fast[self.slaves]))
        return float(fast_slaves * len(self.tris) + self.slaves.size * moved_tris)


@numba.njit(cache=True)
def bin_triangles(x, tris, reach):
    """Bin the triangles on a uniform grid, each into every cell its reach box covers.

    A triangle's box is its bounding sphere's, grown by ``reach``: a node that lies in
    none of the cells it covers is farther than the reach from the triangle. The spacing
    is set by the median triangle (its diameter plus the reach), not the largest, so one
    stretched face (a cracked wall) does not make the whole surface one cell; a triangle
    whose box covers more than ``_OVERSIZED`` cells is instead listed apart and tested
    against every node. The grid holds at most about eight cells per triangle.

    Args:
        x: (n, 3) current node coordinates [mm].
        tris: (n_t, 3) node indices of the triangles.
        reach: Search reach [mm].

    Returns:
        (lower corner (3,), spacing, cells per axis (3,), triangles per cell in CSR form:
        start of each cell's run (n_cells + 1,) and triangle indices, oversized triangle
        indices).
    """
    n_t = tris.shape[0]
    cen = np.zeros((n_t, 3))
    rad = np.zeros(n_t)
    for t in range(n_t):
        for k in range(3):
            cen[t, k] = (x[tris[t, 0], k] + x[tris[t, 1], k] + x[tris[t, 2], k]) / 3.0
        for a in range(3):
            d2 = 0.0
            for k in range(3):
                d2 += (x[tris[t, a], k] - cen[t, k]) ** 2
            rad[t] = max(rad[t], np.sqrt(d2))
    lo, hi = _grid_box(cen, reach)
    size = hi - lo
    h = 2.0 * np.median(rad) + reach + 1e-12
    h = max(h, (size[0] * size[1] * size[2] / (8.0 * n_t + 4096.0)) ** (1.0 / 3.0))
    h = max(h, size.max() / 1024.0)
    dims = np.empty(3, dtype=np.int64)
    for k in range(3):
        dims[k] = int(size[k] / h) + 1
    box = np.empty((n_t, 6), dtype=np.int64)  # cell ranges per triangle, -1: oversized
    start = np.zeros(dims[0] * dims[1] * dims[2] + 1, dtype=np.int64)
    n_big = 0
    for t in range(n_t):
        covered = 1
        for k in range(3):
            box[t, 2 * k] = _cell(cen[t, k] - rad[t] - reach, lo[k], h, dims[k])
            box[t, 2 * k + 1] = _cell(cen[t, k] + rad[t] + reach, lo[k], h, dims[k])
            covered *= box[t, 2 * k + 1] - box[t, 2 * k] + 1
        if covered > _OVERSIZED:
            box[t, 0] = -1
            n_big += 1
            continue
        for c in range(box[t, 4], box[t, 5] + 1):
            for b in range(box[t, 2], box[t, 3] + 1):
                for a in range(box[t, 0], box[t, 1] + 1):
                    start[a + dims[0] * (b + dims[1] * c) + 1] += 1
    for c in range(start.shape[0] - 1):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(start[-1], dtype=np.int64)
    big = np.empty(n_big, dtype=np.int64)
    n_big = 0
    for t in range(n_t):
        if box[t, 0] < 0:
            big[n_big] = t
            n_big += 1
            continue
        for c in range(box[t, 4], box[t, 5] + 1):
            for b in range(box[t, 2], box[t, 3] + 1):
                for a in range(box[t, 0], box[t, 1] + 1):
                    key = a + dims[0] * (b + dims[1] * c)
                    members[fill[key]] = t
                    fill[key] += 1
    return lo, h, dims, start, members, big


@numba.njit(cache=True)
def _grid_box(cen, reach):
    """The grid's box: the triangle centroids' bulk, not their extremes.

    The 0.5% and 99.5% quantiles along each axis, widened by a tenth of their span and
    the reach. A few nodes flung far from the walls (a cracked wall's) would otherwise
    stretch the box, and with it the spacing, until every node tested every triangle; a
    point outside the box falls in its border cells (:func:`_cell` clamps), which keeps
    the search exact.
    """
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(3):
        a = np.percentile(cen[:, k], 0.5)
        b = np.percentile(cen[:, k], 99.5)
        pad = 0.1 * (b - a) + reach
        lo[k] = max(a - pad, cen[:, k].min() - reach)
        hi[k] = min(b + pad, cen[:, k].max() + reach)
    return lo, hi


@numba.njit(cache=True, inline="always")
def _cell(p, lo, h, n):
    """Grid cell of coordinate ``p`` along one axis, clamped to the grid."""
    return min(max(int((p - lo) / h), 0), n - 1)


@numba.njit(cache=True, inline="always")
def _excluded(s, t, tris, tri_cell, ptr, cells):
    """Whether triangle ``t`` holds node ``s`` or lies on a cell node ``s`` belongs to."""
    if tris[t, 0] == s or tris[t, 1] == s or tris[t, 2] == s:
        return True
    for c in range(ptr[s], ptr[s + 1]):
        if cells[c] == tri_cell[t]:
            return True
    return False


@numba.njit(cache=True)
def distance2(x, tris, t, p0, p1, p2):
    """Squared distance from the point ``(p0, p1, p2)`` to triangle ``t``'s nearest point.

    The Voronoi-region test of the closest point on a triangle (Ericson, Real-Time
    Collision Detection, 5.1.5): vertex, edge or face region, in that order.
    """
    a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
    ab0, ab1, ab2 = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    ac0, ac1, ac2 = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
    ap0, ap1, ap2 = p0 - x[a, 0], p1 - x[a, 1], p2 - x[a, 2]
    d1 = ab0 * ap0 + ab1 * ap1 + ab2 * ap2
    d2 = ac0 * ap0 + ac1 * ap1 + ac2 * ap2
    if d1 <= 0.0 and d2 <= 0.0:  # vertex a
        return ap0 * ap0 + ap1 * ap1 + ap2 * ap2
    bp0, bp1, bp2 = p0 - x[b, 0], p1 - x[b, 1], p2 - x[b, 2]
    d3 = ab0 * bp0 + ab1 * bp1 + ab2 * bp2
    d4 = ac0 * bp0 + ac1 * bp1 + ac2 * bp2
    if d3 >= 0.0 and d4 <= d3:  # vertex b
        return bp0 * bp0 + bp1 * bp1 + bp2 * bp2
    vc = d1 * d4 - d3 * d2
    v = 0.0
    w = 0.0
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:  # edge ab
        v = d1 / (d1 - d3)
    else:
        cp0, cp1, cp2 = p0 - x[c, 0], p1 - x[c, 1], p2 - x[c, 2]
        d5 = ab0 * cp0 + ab1 * cp1 + ab2 * cp2
        d6 = ac0 * cp0 + ac1 * cp1 + ac2 * cp2
        if d6 >= 0.0 and d5 <= d6:  # vertex c
            return cp0 * cp0 + cp1 * cp1 + cp2 * cp2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:  # edge ac
            w = d2 / (d2 - d6)
        elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:  # edge bc
            w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            v = 1.0 - w
        elif va + vb + vc > 0.0:  # the face
            v = vb / (va + vb + vc)
            w = vc / (va + vb + vc)
    q0 = ap0 - v * ab0 - w * ac0
    q1 = ap1 - v * ab1 - w * ac1
    q2 = ap2 - v * ab2 - w * ac2
    return q0 * q0 + q1 * q1 + q2 * q2


@numba.njit(cache=True)
def candidates(x, tris, tri_cell, ptr, cells, slaves, reach, tri_dead, node_dead):
    """The triangles within ``reach`` of each slave: a Verlet list, searched afresh.

    Every triangle not excluded (:func:`_excluded`) whose nearest point lies within
    ``reach`` of the slave, in ascending order.

    Args:
        x: (n, 3) current node coordinates [mm].
        tris: (n_t, 3) triangles.
        tri_cell: (n_t,) global cell of each triangle.
        ptr: (n + 1,) offsets into ``cells`` per node.
        cells: Global indices of the cells each node belongs to.
        slaves: Indices of the nodes to test.
        reach: The farthest a contact registers plus the motion the list must survive
            [mm].
        tri_dead: (n_t,) triangles on eroded cells (left out).
        node_dead: (n,) nodes of eroded cells only (left out).

    Returns:
        (offsets (n_s + 1,), triangle indices) per slave.
    """
    n_s = slaves.shape[0]
    reach2 = reach * reach
    count = np.zeros(n_s + 1, dtype=np.int64)
    live = np.flatnonzero(~tri_dead)
    if live.size == 0:
        return count, np.zeros(0, dtype=np.int64)
    lo, h, dims, start, members, big = bin_triangles(x, tris[live], reach)
    box = _boxes(x, tris, reach)
    found = []
    mine = []
    for i in range(n_s):
        s = slaves[i]
        if node_dead[s]:
            continue
        p0, p1, p2 = x[s, 0], x[s, 1], x[s, 2]
        key = (_cell(p0, lo[0], h, dims[0]) + dims[0] * (
            _cell(p1, lo[1], h, dims[1]) + dims[1] * _cell(p2, lo[2], h, dims[2])))
        mine.clear()
        for r in range(start[key], start[key + 1] + big.shape[0]):
            t = live[members[r] if r < start[key + 1] else big[r - start[key + 1]]]
            if (p0 < box[t, 0] or p0 > box[t, 1] or p1 < box[t, 2] or p1 > box[t, 3]
                    or p2 < box[t, 4] or p2 > box[t, 5]):
                continue
            if _excluded(s, t, tris, tri_cell, ptr, cells):
                continue
            if distance2(x, tris, t, p0, p1, p2) <= reach2:
                mine.append(t)
        mine.sort()
        found.extend(mine)
        count[i + 1] = len(mine)
    return _compressed(count, found)


@numba.njit(cache=True)
def _compressed(count, found):
    """Per-slave counts and their triangles in turn, as offsets and one index array."""
    for i in range(count.shape[0] - 1):
        count[i + 1] += count[i]
    out = np.empty(len(found), dtype=np.int64)
    for j in range(len(found)):
        out[j] = found[j]
    return count, out


@numba.njit(cache=True)
def _boxes(x, tris, reach):
    """(n_t, 6) each triangle's bounding box grown by ``reach``: low and high x, y, z."""
    box = np.empty((tris.shape[0], 6))
    for t in range(tris.shape[0]):
        for k in range(3):
            a, b, c = x[tris[t, 0], k], x[tris[t, 1], k], x[tris[t, 2], k]
            box[t, 2 * k] = min(a, b, c) - reach
            box[t, 2 * k + 1] = max(a, b, c) + reach
    return box


@numba.njit(cache=True)
def refresh(x, tris, tri_cell, ptr, cells, slaves, offsets, cand, fast, reach, tri_dead,
            node_dead):
    """The list of :func:`candidates` updated for fast nodes and eroded cells.

    A fast slave's list is searched afresh against every live triangle; every other
    slave keeps its live candidates that have no fast vertex, and is tested again
    against the triangles that do. Triangles on eroded cells, and slaves that only
    eroded cells hold, leave the list. Each search is a test of every pair, behind a
    bounding-box check: cheaper than the binned search for a few tens of fast nodes.
    The test is written out here as in :func:`candidates`: as one shared compiled
    function it made the full search four to five times slower.

    Args:
        x: (n, 3) current node coordinates [mm].
        tris: (n_t, 3) triangles.
        tri_cell: (n_t,) global cell of each triangle.
        ptr: (n + 1,) offsets into ``cells`` per node.
        cells: Global indices of the cells each node belongs to.
        slaves: Indices of the nodes to test.
        offsets: (n_s + 1,) the list's offsets per slave.
        cand: The list's triangles.
        fast: (n,) the nodes whose pairs are searched again.
        reach: Reach of the new search [mm].
        tri_dead: (n_t,) triangles on eroded cells.
        node_dead: (n,) nodes of eroded cells only.

    Returns:
        (offsets (n_s + 1,), triangle indices) per slave, in ascending order.
    """
    n_t = tris.shape[0]
    n_s = slaves.shape[0]
    reach2 = reach * reach
    box = _boxes(x, tris, reach)
    moved = np.zeros(n_t, dtype=np.bool_)  # a live triangle with a fast vertex
    for t in range(n_t):
        moved[t] = not tri_dead[t] and (fast[tris[t, 0]] or fast[tris[t, 1]]
                                         or fast[tris[t, 2]])
    live = np.flatnonzero(~tri_dead)
    shifted = np.flatnonzero(moved)
    count = np.zeros(n_s + 1, dtype=np.int64)
    found = []
    mine = []
    for i in range(n_s):
        s = slaves[i]
        if node_dead[s]:
            continue
        mine.clear()
        if fast[s]:
            pool = live
        else:
            pool = shifted
            for r in range(offsets[i], offsets[i + 1]):
                t = cand[r]
                if not tri_dead[t] and not moved[t]:
                    mine.append(t)
        p0, p1, p2 = x[s, 0], x[s, 1], x[s, 2]
        for t in pool:
            if (p0 < box[t, 0] or p0 > box[t, 1] or p1 < box[t, 2] or p1 > box[t, 3]
                    or p2 < box[t, 4] or p2 > box[t, 5]):
                continue
            if _excluded(s, t, tris, tri_cell, ptr, cells):
                continue
            if distance2(x, tris, t, p0, p1, p2) <= reach2:
                mine.append(t)
        mine.sort()
        found.extend(mine)
        count[i + 1] = len(mine)
    return _compressed(count, found)
