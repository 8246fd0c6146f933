"""Rigid tools given as triangulated surfaces: STL, OBJ, PLY, gmsh meshes, STEP/IGES.

A :class:`SurfaceTool` is a tool shape like those of :mod:`forming.contact.shapes`:
a signed distance, positive outside the tool. The tool is the side its triangles'
normals point away from: a closed surface with outward normals (a punch) is the solid it
encloses; an open sheet (``sheet=True``, one working face of a die) has the tool behind
it, and ``flip=True`` turns it round.

The distance is the exact distance to the triangles. Its sign is that of ``(x - c) . n``
with ``c`` the closest point and ``n`` the angle-weighted pseudo-normal of the feature
``c`` lies on (face, edge or vertex; Baerentzen & Aanaes 2005), so it is right next to
edges and vertices too, on both faces of a sheet. The normal a contact needs is the
distance's gradient, ``sign (x - c) / |x - c|``, continuous across edges; on the
surface itself the feature's pseudo-normal.

The closest facet comes from fcpw's bounding-volume hierarchy (single precision, built
once in coordinates centred on the tool); the closest point is then found in double
precision on that facet's one-ring (``_project_local``), which also settles the tree's
rounding. Within a load step, :class:`FacetTracker` keeps each point's facet and only
walks over one-rings. The surface is read on rank 0 and every rank holds a copy
(a tool surface of 10^6 triangles takes about 100 MB per rank).

Bad surfaces get an :class:`~forming.errors.InputError` naming the file and the fault:
unreadable, no triangles, non-manifold edges, inconsistent orientation, open where a
closed solid is declared.
"""

from __future__ import annotations

import atexit
import functools
import logging
import math
import time
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numba
import numpy as np
from mpi4py import MPI

from forming.cad import Tessellation, orient_outward, triangles
from forming.errors import InputError

log = logging.getLogger(__name__)

_LIVE: weakref.WeakSet = weakref.WeakSet()  # surfaces whose trees outlive a run


@atexit.register
def _release_trees() -> None:
    """Free the search trees before interpreter shutdown.

    A tree still referenced from a reference cycle at exit makes nanobind (fcpw's
    bindings) print leak warnings for every bound function.
    """
    for surface in list(_LIVE):
        surface.release()


_CAD = {".step", ".stp", ".iges", ".igs", ".brep"}
_MESH = {".stl", ".obj", ".ply", ".off", ".msh", ".vtk", ".vtu"}


# -- reading --------------------------------------------------------------------------
def _read_cad(path: Path, tess: Tessellation) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the faces of a CAD file with gmsh's OpenCASCADE kernel."""
    import gmsh

    started = gmsh.isInitialized()
    if not started:
        gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(f"tool_{path.stem}")
    try:
        gmsh.model.occ.importShapes(str(path))
        gmsh.model.occ.synchronize()
        tess.apply(gmsh)
        gmsh.model.mesh.generate(2)
        if 2 not in list(gmsh.model.mesh.getElements(2)[0]):
            raise InputError("tool.path", f"{path}: the CAD file has no faces to mesh")
        vertices, faces = triangles(gmsh)
    except InputError:
        raise
    except Exception as exc:  # gmsh raises a bare Exception with its log line
        raise InputError("tool.path", f"{path}: gmsh could not read or mesh it ({exc})") \
            from exc
    finally:
        gmsh.model.remove()
        if not started:
            gmsh.finalize()
    # a CAD solid's faces come in their own parametric orientations
    return vertices, orient_outward(vertices, faces)


def _read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import meshio

    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many types for a broken file
        raise InputError("tool.path", f"{path}: not a readable surface mesh ({exc})") from exc
    tris = [np.asarray(b.data, dtype=np.int64) for b in m.cells if b.type == "triangle"]
    if not tris:
        raise InputError("tool.path", f"{path}: has no triangles "
                         f"(cell types: {sorted({b.type for b in m.cells}) or 'none'})")
    return np.asarray(m.points, dtype=float)[:, :3], np.vstack(tris)


def read_triangles(path: Path, tess: Tessellation) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) and triangles (m, 3) of a surface file.

    Args:
        path: STL, OBJ, PLY, OFF, gmsh or VTK surface mesh, or a STEP/IGES/BREP model.
        tess: How finely a CAD model is triangulated (sizes in the file's units).
    """
    suffix = path.suffix.lower()
    if suffix not in _CAD | _MESH:
        raise InputError("tool.path", f"{path}: unknown surface format {suffix!r} "
                         f"(one of {', '.join(sorted(_CAD | _MESH))})")
    if not path.is_file():
        raise InputError("tool.path", f"{path}: no such file")
    return _read_cad(path, tess) if suffix in _CAD else _read_mesh(path)


# -- topology and checks ----------------------------------------------------------------
def _merge(vertices: np.ndarray, faces: np.ndarray, tol: float):
    """Merge coincident vertices (an STL stores each triangle's own three)."""
    keys = np.round(vertices / tol).astype(np.int64)
    _u, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return vertices[first], inverse.reshape(-1)[faces]


def _edges(faces: np.ndarray):
    """Directed edges ``k`` of each face (``F[f, k] -> F[f, k+1]``) and undirected ids."""
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    _u, edge, counts = np.unique(np.stack([lo, hi], axis=1), axis=0, return_inverse=True,
                                 return_counts=True)
    return a, b, edge.reshape(-1), counts


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


# 3-vectors as tuples of floats: no heap allocation inside the kernels
@numba.njit(cache=True, inline="always")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(cache=True, inline="always")
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@numba.njit(cache=True, inline="always")
def _axpy(t, x, y):
    """``y + t x``."""
    return (y[0] + t * x[0], y[1] + t * x[1], y[2] + t * x[2])


@numba.njit(cache=True, inline="always")
def _vec(rows, i):
    return (rows[i, 0], rows[i, 1], rows[i, 2])


@numba.njit(cache=True)
def _closest_on_triangle(x, a, b, c):
    """Closest point of triangle abc to x and its feature (Ericson 2005, sec. 5.1.5).

    Feature: 0 face, 1/2/3 vertex a/b/c, 4/5/6 edge ab/bc/ca.
    """
    ab = _sub(b, a)
    ac = _sub(c, a)
    ap = _sub(x, a)
    d1 = _dot(ab, ap)
    d2 = _dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return a, 1
    bp = _sub(x, b)
    d3 = _dot(ab, bp)
    d4 = _dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return b, 2
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        return _axpy(d1 / (d1 - d3), ab, a), 4
    cp = _sub(x, c)
    d5 = _dot(ab, cp)
    d6 = _dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return c, 3
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        return _axpy(d2 / (d2 - d6), ac, a), 6
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return _axpy(w, _sub(c, b), b), 5
    denom = 1.0 / (va + vb + vc)
    return _axpy(vc * denom, ac, _axpy(vb * denom, ab, a)), 0


@numba.njit(cache=True, inline="always")
def _on_facet(x, f, vertices, faces):
    return _closest_on_triangle(x, _vec(vertices, faces[f, 0]), _vec(vertices, faces[f, 1]),
                                _vec(vertices, faces[f, 2]))


@numba.njit(cache=True)
def _project(points, cand, vertices, faces, fn, en, vn, out_d, out_n, out_c, out_k):
    """Signed distance, outward normal and closest point of each point on its facet.

    ``out_k``: the normal's derivative with respect to the point, ``dn/dx``: zero on a
    face, ``s (I - n n) / d`` at a vertex and ``s (I - n n - t t) / d`` on an edge of
    tangent ``t`` (``s`` the sign, ``d`` the distance).
    """
    for i in range(points.shape[0]):
        f = cand[i]
        x = _vec(points, i)
        c, feature = _on_facet(x, f, vertices, faces)
        if feature == 0:
            pn = _vec(fn, f)
        elif feature <= 3:
            pn = _vec(vn, faces[f, feature - 1])
        else:
            k = feature - 4
            pn = (en[f, k, 0], en[f, k, 1], en[f, k, 2])
        r = _sub(x, c)
        dist = math.sqrt(_dot(r, r))
        sign = 1.0 if _dot(r, pn) >= 0.0 else -1.0
        out_d[i] = sign * dist
        for j in range(3):
            out_c[i, j] = c[j]
            out_n[i, j] = (sign / dist) * r[j] if dist > 1e-12 else pn[j]
        t = (0.0, 0.0, 0.0)
        if feature >= 4:
            k = feature - 4
            e = _sub(_vec(vertices, faces[f, (k + 1) % 3]), _vec(vertices, faces[f, k]))
            length = math.sqrt(_dot(e, e))
            t = (e[0] / length, e[1] / length, e[2] / length)
        scale = sign / dist if (feature != 0 and dist > 1e-12) else 0.0
        for a in range(3):
            for b in range(3):
                out_k[i, a, b] = scale * ((a == b) - out_n[i, a] * out_n[i, b] - t[a] * t[b])


@numba.njit(cache=True)
def _project_local(points, facet, ring_ptr, ring, vertices, faces, fn, en, vn, out_d, out_n,
                   out_c, out_k):
    """As :func:`_project`, each point on the closest of its facet's one-ring.

    The one-ring is the facet and every facet sharing a vertex with it; ``facet`` is
    updated to the closest one, so a point that slides walks across the surface.
    """
    for i in range(points.shape[0]):
        x = _vec(points, i)
        best = facet[i]
        best_r2 = np.inf
        for k in range(ring_ptr[facet[i]], ring_ptr[facet[i] + 1]):
            f = ring[k]
            c, _feature = _on_facet(x, f, vertices, faces)
            r = _sub(x, c)
            r2 = _dot(r, r)
            if r2 < best_r2:
                best_r2 = r2
                best = f
        facet[i] = best
    _project(points, facet, vertices, faces, fn, en, vn, out_d, out_n, out_c, out_k)


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
    pairs = np.unique(owner * m + other)
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

    def query(self, points: np.ndarray):
        """Distance, normal, closest point and ``dn/dx`` (see TriangleSurface.query)."""
        s = self.surface
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        if self._facet is None or len(self._facet) != len(points):
            self._facet = s.closest_facets(points)
        return s.query(points, self._facet)

    def gap_normal(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) and outward normal (n, 3) of the (n, 3) points."""
        d, n, _c, _k = self.query(points)
        return d, n


class TriangleSurface:
    """A checked triangle surface with its search tree.

    Args:
        vertices: (n, 3) coordinates [mm].
        faces: (m, 3) vertex indices, oriented so normals point out of the tool.
        name: What error messages call it (the file).
        sheet: An open surface is allowed (one working face).
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, name: str, sheet: bool):
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
        _LIVE.add(self)

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

    def query(self, points: np.ndarray, facets: np.ndarray | None = None):
        """Signed distance, outward normal, closest point and the normal's derivative.

        Args:
            points: (n, 3) points.
            facets: Their closest facets if known (:meth:`closest_facets`); each is
                updated to the closest facet of its one-ring.

        Returns:
            The distance (n,), the normal (n, 3), the closest point (n, 3) and
            ``dn/dx`` (n, 3, 3), zero where the closest point is inside a facet.
        """
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        t0 = time.perf_counter()
        n = len(points)
        d, nrm, c, k = np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3, 3))
        if n:
            if facets is None:
                facets = self.closest_facets(points)
            # the tree's single precision may pick a facet up to ~1e-5 mm farther than
            # the closest: the one-ring settles it in double precision
            ptr, ring = self.one_rings
            _project_local(points, facets, ptr, ring, self.vertices, self.faces, self.fn,
                           self.en, self.vn, d, nrm, c, k)
        self.seconds += time.perf_counter() - t0
        return d, nrm, c, k


def _load(path: Path, sheet: bool, flip: bool, scale: float, translate, tess: Tessellation,
          comm: MPI.Comm) -> TriangleSurface:
    """Read on rank 0, broadcast, check and build on every rank (errors on every rank)."""
    data = None
    if comm.rank == 0:
        try:
            data = read_triangles(path, Tessellation(tess.angle, tess.max_size / scale))
        except InputError as exc:  # (not picklable: its field and message go)
            data = (exc.field, str(exc).removeprefix(f"{exc.field}: "))
    data = comm.bcast(data, root=0)
    if isinstance(data[0], str):
        raise InputError(*data)
    vertices, faces = data
    vertices = vertices * scale + np.asarray(translate, dtype=float)
    if flip:
        faces = faces[:, [0, 2, 1]]
    return TriangleSurface(vertices, faces, str(path), sheet)


@dataclass(frozen=True)
class SurfaceTool:
    """A rigid tool given by a triangulated surface file (see the module docstring).

    Attributes:
        path: The surface file.
        sheet: The surface is one open working face, not a closed solid.
        flip: Turn the triangles round (the tool is on the other side).
        scale: Factor from the file's units to mm (1000 for a file in metres).
        translate: Moved by this after scaling [mm].
        tessellation: How finely a CAD model is triangulated (sizes in mm).
    """

    tracked: ClassVar[bool] = True  # no UFL expression: the contact tracks closest points

    path: Path
    sheet: bool = False
    flip: bool = False
    scale: float = 1.0
    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tessellation: Tessellation = Tessellation()
    surface: TriangleSurface = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise InputError("tool.scale", f"must be a positive number, got {self.scale!r}")
        object.__setattr__(self, "surface", _load(self.path, self.sheet, self.flip,
                                                  self.scale, self.translate,
                                                  self.tessellation, MPI.COMM_WORLD))

    def distance(self, p, xp):
        """Signed distance of the (3, ...) points ``p`` (NumPy only)."""
        if not isinstance(p, np.ndarray):
            raise TypeError(f"{self.path}: a surface tool's distance is not a UFL expression")
        d, _n, _c, _k = self.surface.query(p.reshape(3, -1).T)
        return d.reshape(p.shape[1:])

    def gap_normal(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) and outward normal (n, 3) of the (n, 3) points."""
        d, n, _c, _k = self.surface.query(points)
        return d, n

    def tracker(self) -> FacetTracker:
        """A closest-point tracker for points that move a little between queries."""
        return FacetTracker(self.surface)

    def polydata(self):
        """The triangles as a :class:`pyvista.PolyData` (outputs, pictures)."""
        import pyvista

        s = self.surface
        cells = np.hstack([np.full((len(s.faces), 1), 3), s.faces]).ravel()
        return pyvista.PolyData(s.vertices.copy(), cells)

    @property
    def search_seconds(self) -> float:
        """Time spent in closest-point queries so far [s]."""
        return self.surface.seconds

    def check_units(self, extent: float) -> None:
        """Refuse a surface whose size is far off the blank's ``extent`` [mm]."""
        ratio = self.surface.extent / extent
        if not 1e-2 <= ratio <= 1e3:
            raise InputError("tool.scale", f"{self.path}: the surface is {self.surface.extent:.4g}"
                             f" mm across, the blank {extent:.4g} mm: are its units mm? "
                             "(scale converts them)")
