"""Checked triangle surfaces with a closest-point search (the geometry of surface tools).

:class:`TriangleSurface` merges an STL's coincident vertices, drops zero-area
triangles, refuses non-manifold edges, inconsistent orientation and (for a closed
solid) an open surface, and prepares what the kernels of :mod:`forming.contact.closest`
need: pseudo-normals for the sign, corner normals and crease flags for the smoothed
traction direction, one-rings for tracking, and fcpw's tree for the search.

The closest facet comes from fcpw's bounding-volume hierarchy (single precision, built
once in coordinates centred on the tool); the closest point is then found in double
precision on that facet's one-ring, which also settles the tree's rounding. Within a
load step, :class:`FacetTracker` keeps each point's facet and only walks over one-rings.
"""

from __future__ import annotations

import functools
import logging
import math
import time
import weakref
from typing import NamedTuple

import numpy as np

from forming.contact.closest import closest_in_rings, corner_normals, project
from forming.errors import InputError

log = logging.getLogger(__name__)

CREASE_DEG = 30.0  # default: edges sharper than this are not smoothed over

LIVE: weakref.WeakSet = weakref.WeakSet()  # surfaces whose trees outlive a run


class Closest(NamedTuple):
    """What a query returns for n points.

    Attributes:
        distance: (n,) signed distance, positive outside the tool [mm].
        normal: (n, 3) its gradient (the gap's normal).
        point: (n, 3) the closest point.
        direction: (n, 3) the traction's direction (smoothed normal).
        rotation: (n, 3, 3) the direction's derivative with respect to the point.
    """

    distance: np.ndarray
    normal: np.ndarray
    point: np.ndarray
    direction: np.ndarray
    rotation: np.ndarray


# np.unique is not used on these arrays: with ``axis=0`` it sorts rows as structured
# records, and numpy 2.5 hashes 1-D integers before it sorts them; the sorts below give
# the same arrays about ten times faster (a 105,218-facet tool: its edges 0.53 -> 0.05 s,
# its one-rings 2.2 -> 0.19 s, measured 2026-12-03).
def _firsts(ordered: np.ndarray) -> np.ndarray:
    """Where each run of equal rows (or values) of a sorted array starts."""
    new = np.empty(len(ordered), dtype=bool)
    new[:1] = True
    differs = ordered[1:] != ordered[:-1]
    new[1:] = differs.any(axis=1) if differs.ndim == 2 else differs
    return new


def _groups(keys: np.ndarray, order: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run starts of ``keys[order]`` (sorted) and each key's group, numbered in that order."""
    new = _firsts(keys[order])
    group = np.empty(len(keys), dtype=np.int64)
    group[order] = np.cumsum(new) - 1
    return new, group


def _merge(vertices: np.ndarray, faces: np.ndarray, tol: float):
    """Merge coincident vertices (an STL stores each triangle's own three).

    The merged vertices are ordered by their rounded coordinates (x, then y, then z),
    each represented by its first occurrence.
    """
    keys = np.round(vertices / tol).astype(np.int64)
    order = np.lexsort(keys.T[::-1])  # stable: equal keys keep their input order
    new, inverse = _groups(keys, order)
    return vertices[order[new]], inverse[faces]


def _edges(faces: np.ndarray):
    """Directed edges ``k`` of each face (``F[f, k] -> F[f, k+1]``) and undirected ids.

    Undirected edges are numbered in the order of their (lower, higher) vertex pairs;
    ``counts`` is the number of face edges on each.
    """
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * (int(faces.max()) + 1) + hi
    _new, edge = _groups(key, np.argsort(key, kind="stable"))
    return a, b, edge, np.bincount(edge)


def _check(name: str, vertices, faces, sheet: bool):
    """Topology checks; returns the undirected edge id of each face edge (m, 3)."""
    a, b, edge, counts = _edges(faces)
    if (bad := np.flatnonzero(counts > 2)).size:
        e = np.flatnonzero(edge == bad[0])[0]
        raise InputError("tool.path", f"{name}: {bad.size} non-manifold edges (more than two "
                         f"triangles on one edge), e.g. at {vertices[a[e]].round(3).tolist()}")
    # a manifold edge must be traversed once in each direction by its two triangles
    order = np.argsort(edge, kind="stable")
    shared = counts[edge[order]] == 2
    first, second = order[shared][0::2], order[shared][1::2]
    same = a[first] == a[second]
    if same.any():
        raise InputError("tool.path", f"{name}: inconsistent orientation: {int(same.sum())} "
                         "edges where neighbouring triangles face opposite ways, e.g. at "
                         f"{vertices[a[first[same][0]]].round(3).tolist()}")
    boundary = int((counts == 1).sum())
    if boundary and not sheet:
        raise InputError("tool.path", f"{name}: the surface is open ({boundary} boundary "
                         "edges) but the tool is declared a closed solid; give sheet=true "
                         "if it is one working face (the tool is on the side its normals "
                         "point away from)")
    return edge.reshape(-1, 3), counts


def _pseudo_normals(vertices, faces, edge, counts):
    """Unit face normals, face-edge pseudo-normals (m, 3, 3) and vertex pseudo-normals."""
    p = vertices[faces]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    fn /= np.linalg.norm(fn, axis=1)[:, None]
    # edges: the sum of the (one or two) adjacent face normals
    acc = np.zeros((len(counts), 3))
    np.add.at(acc, edge.reshape(-1), np.repeat(fn, 3, axis=0))
    en = acc[edge]
    en /= np.linalg.norm(en, axis=2)[:, :, None]
    # vertices: face normals weighted by the face's angle at the vertex
    vn = np.zeros_like(vertices)
    for k in range(3):
        e1 = p[:, (k + 1) % 3] - p[:, k]
        e2 = p[:, (k + 2) % 3] - p[:, k]
        cos = np.sum(e1 * e2, axis=1) / (np.linalg.norm(e1, axis=1)
                                           * np.linalg.norm(e2, axis=1))
        np.add.at(vn, faces[:, k], np.arccos(np.clip(cos, -1.0, 1.0))[:, None] * fn)
    vn /= np.linalg.norm(vn, axis=1)[:, None]
    return fn, en, vn



def _smoothing(vertices, faces, fn, edge, counts, cos_crease: float):
    """Corner normals (m, 3, 3), smooth face edges (m, 3) and smooth vertices (nv,)."""
    m = len(faces)
    # faces round each vertex with their angle there
    p = vertices[faces]
    angles = np.empty((m, 3))
    for k in range(3):
        e1 = p[:, (k + 1) % 3] - p[:, k]
        e2 = p[:, (k + 2) % 3] - p[:, k]
        cos = np.sum(e1 * e2, axis=1) / (np.linalg.norm(e1, axis=1)
                                           * np.linalg.norm(e2, axis=1))
        angles[:, k] = np.arccos(np.clip(cos, -1.0, 1.0))
    order = np.argsort(faces.reshape(-1), kind="stable")
    vf_ptr = np.searchsorted(faces.reshape(-1)[order], np.arange(len(vertices) + 1))
    cn = corner_normals(faces, fn, vf_ptr, order // 3, angles.reshape(-1)[order], cos_crease)
    # an edge is smooth when it has two faces within the crease angle
    flat = edge.reshape(-1)
    first = np.full(len(counts), -1)
    other = np.full(len(counts), -1)
    owner = np.repeat(np.arange(m), 3)
    first[flat[::-1]] = owner[::-1]  # the first face of each edge
    other[flat] = owner  # the last
    dot = np.einsum("ij,ij->i", fn[first], fn[other])
    smooth = (counts == 2) & (dot >= cos_crease)
    smooth_edge = smooth[edge]
    smooth_vertex = np.ones(len(vertices), dtype=bool)
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    rough = ~smooth_edge.reshape(-1)
    smooth_vertex[a[rough]] = False
    smooth_vertex[b[rough]] = False
    return cn, smooth_edge, smooth_vertex


def _one_rings(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the facets sharing a vertex with each facet (itself included)."""
    m = len(faces)
    vf_v = faces.reshape(-1)
    vf_f = np.repeat(np.arange(m), 3)
    order = np.argsort(vf_v, kind="stable")
    vf_v, vf_f = vf_v[order], vf_f[order]
    starts = np.searchsorted(vf_v, np.arange(int(faces.max()) + 2))
    rows = []
    for k in range(3):
        v = faces[:, k]
        lengths = starts[v + 1] - starts[v]
        idx = np.repeat(starts[v], lengths) + (np.arange(lengths.sum())
                                               - np.repeat(np.cumsum(lengths) - lengths,
                                                           lengths))
        rows.append((np.repeat(np.arange(m), lengths), vf_f[idx]))
    owner = np.concatenate([r[0] for r in rows])
    other = np.concatenate([r[1] for r in rows])
    pairs = np.sort(owner * m + other)
    pairs = pairs[_firsts(pairs)]
    owner, other = pairs // m, pairs % m
    ptr = np.searchsorted(owner, np.arange(m + 1))
    return ptr.astype(np.int64), other.astype(np.int64)



class FacetTracker:
    """Closest points of a fixed set of points that move a little between queries.

    The first query after :meth:`repair` searches the tree (pairing each point with
    its closest facet); the following ones project each point onto its paired facet's
    one-ring and move the pairing to the closest facet there. So a point that slides
    walks from facet to facet, and the tree is searched once per load step (implicit)
    or output interval (explicit).
    """

    def __init__(self, surface: TriangleSurface):
        self.surface = surface
        self._facet: np.ndarray | None = None

    def repair(self) -> None:
        """Search the tree at the next query."""
        self._facet = None

    def query(self, points: np.ndarray) -> Closest:
        """See :meth:`TriangleSurface.query`."""
        s = self.surface
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        if self._facet is None or len(self._facet) != len(points):
            self._facet = s.closest_facets(points)
        return s.query(points, self._facet)

    def gap_normal(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) and traction direction (n, 3) of the (n, 3) points."""
        q = self.query(points)
        return q.distance, q.direction


class TriangleSurface:
    """A checked triangle surface with its search tree.

    Args:
        vertices: (n, 3) coordinates [mm].
        faces: (m, 3) vertex indices, oriented so normals point out of the tool.
        name: What error messages call it (the file).
        sheet: An open surface is allowed (one working face).
        crease: Edges whose faces meet at more than this angle are sharp [deg]: the
            traction's direction is not smoothed across them.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, name: str, sheet: bool,
                 crease: float = CREASE_DEG):
        import fcpw

        if faces.size == 0:
            raise InputError("tool.path", f"{name}: has no triangles")
        extent = float(np.ptp(vertices, axis=0).max())
        if not math.isfinite(extent) or extent <= 0.0:
            raise InputError("tool.path", f"{name}: coordinates are degenerate or not finite")
        vertices, faces = _merge(vertices, faces, 1e-9 * extent)
        p = vertices[faces]
        area2 = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        keep = area2 > 1e-12 * extent * extent
        if not keep.any():
            raise InputError("tool.path", f"{name}: every triangle has zero area")
        if (dropped := int((~keep).sum())):
            log.info("%s: %d zero-area triangles ignored", name, dropped)
        faces = faces[keep]
        edge, counts = _check(name, vertices, faces, sheet)
        self.name = name
        self.vertices = vertices
        self.faces = faces
        self.boundary_edges = int((counts == 1).sum())
        self.fn, self.en, self.vn = _pseudo_normals(vertices, faces, edge, counts)
        self.cn, self.smooth_edge, self.smooth_vertex = _smoothing(
            vertices, faces, self.fn, edge, counts, math.cos(math.radians(crease)))
        self.lower = vertices.min(axis=0)
        self.upper = vertices.max(axis=0)
        self.extent = extent
        self._centre = 0.5 * (self.lower + self.upper)
        self._scene = fcpw.scene_3D()
        self._scene.set_object_count(1)
        self._scene.set_object_vertices(np.asarray(vertices - self._centre, dtype=np.float32),
                                        0)
        self._scene.set_object_triangles(faces.astype(np.int32), 0)
        self._scene.build(fcpw.aggregate_type.bvh_surface_area, True)
        self._fcpw = fcpw
        self.seconds = 0.0  # spent in queries [s]
        LIVE.add(self)

    def release(self) -> None:
        """Drop the search tree (at exit; the surface cannot be queried after)."""
        self._scene = None

    @property
    def edge_lengths(self) -> np.ndarray:
        """Length of every triangle edge [mm] (each inner edge twice)."""
        p = self.vertices[self.faces]
        return np.linalg.norm(p[:, [1, 2, 0]] - p, axis=2).reshape(-1)

    def closest_facets(self, points: np.ndarray) -> np.ndarray:
        """Index of the closest triangle of each of the (n, 3) points."""
        out = self._fcpw.interaction_3D_list()
        q = np.asfortranarray(points - self._centre, dtype=np.float32)
        self._scene.find_closest_points(q, np.full(len(q), np.inf, dtype=np.float32), out)
        return np.fromiter((i.primitive_index for i in out), dtype=np.int64, count=len(q))

    @functools.cached_property
    def one_rings(self) -> tuple[np.ndarray, np.ndarray]:
        """CSR lists of the facets sharing a vertex with each facet (local tracking)."""
        return _one_rings(self.faces)

    def query(self, points: np.ndarray, facets: np.ndarray | None = None) -> Closest:
        """Distance, normal, closest point, traction direction and its derivative.

        Args:
            points: (n, 3) points.
            facets: Their closest facets if known (:meth:`closest_facets`); each is
                updated to the closest facet of its one-ring.
        """
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        t0 = time.perf_counter()
        n = len(points)
        out = Closest(np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
                      np.empty((n, 3, 3)))
        if n:
            if facets is None:
                facets = self.closest_facets(points)
            # the tree's single precision may pick a facet up to ~1e-5 mm farther than
            # the closest: the one-ring settles it in double precision
            ptr, ring = self.one_rings
            closest_in_rings(points, facets, ptr, ring, self.vertices, self.faces)
            project(points, facets, self.vertices, self.faces, self.fn, self.en, self.vn,
                    self.cn, self.smooth_edge, self.smooth_vertex, *out)
        self.seconds += time.perf_counter() - t0
        return out
