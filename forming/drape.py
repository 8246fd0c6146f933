"""Kinematic draping: a pin-jointed net of two fibre families laid onto a tool surface.

The fabric is a net of inextensible edges of length ``d`` (the spacing) joined at pins
that turn freely: the only way it takes a doubly curved shape is by shear, the change of
the angle between the two fibre families. Nothing else is modelled (friction, a blank
holder, draw-in, the core under the skin: docs/theory.md, section 14).

The construction (van West, Pipes and Keefe 1990; the generator arms as in KinDrape,
Krogh et al. 2021):

1. The origin node is pinned at the start point; its neighbour along the second family is
   the point of the surface at distance ``d`` in the vertical plane at the plan-view angle
   ``angle + 90`` deg.
2. Four generator arms grow from the origin cell, one strip of cells along each fibre
   direction. Each arm cell has two known nodes and one free angle, that of its edge
   leaving the first known node; the angle is found by Newton so that the cell's mean
   signed shear vanishes (KinDrape_eff_NR's criterion; the paper's KinDrape minimises the
   sum of the corners' absolute shears, which gives the same arms on its hemisphere test).
3. The four quadrants between the arms are filled node by node: the free node of a cell
   is where the spheres of radius ``d`` around its two known neighbours meet the surface
   (a three-equation Newton from the parallelogram guess ``a + b - c``).

A node that cannot be placed (off the surface's extent, spheres that do not meet, a cell
that folds over) is NaN, and so is every node that depends on it: the net stops there.

**Sign convention.** At a corner of a cell the shear angle is ``gamma = 90 - theta`` [deg],
where ``theta`` is the angle between the edges that run along increasing row index (the
first family) and increasing column index (the second family). ``gamma > 0`` when the
families close, as for the fabric skins (:mod:`forming.materials.fabric`): with
``angle = -45`` the families lie at -45 and +45 deg, and positive shear closes them around
the x-axis. A cell's shear is the mean of its four corners.

A surface is anything with ``evaluate(points) -> (distance, gradient)`` and
``contains(points)``: :class:`ShapeSurface` wraps the signed-distance tool shapes of
:mod:`forming.contact.shapes`; a triangulated surface can implement the same two methods.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from forming.errors import InputError
from forming.surfaces import ShapeSurface, Surface, finite_point, project  # noqa: F401

_TOL = 1e-12  # node equations, relative to the spacing; arm shear [rad]
_MAX_ITER = 50


@dataclass(frozen=True)
class DrapeSettings:
    """Settings of a kinematic drape (mm, deg).

    Attributes:
        start: Where the origin node is pinned [mm]: a point on the surface (within half
            a spacing of it; it is moved onto it).
        spacing: Net spacing ``d``, the length of every edge [mm].
        nodes: Nodes of the net (rows along the first family, columns along the second).
        angle: Plan-view angle of the first fibre family (rows) from the x-axis [deg];
            the second family starts at ``angle + 90``.
        origin: Grid index (row, column) of the origin node; None: the middle,
            ``((rows - 1) // 2, (columns - 1) // 2)``. The origin cell is the one at
            ``origin`` and ``origin + (1, 1)``.
        side: +1: the net lies where the tool's distance is positive (outside it);
            -1: inside.
        clearance: Distance of the net from the surface on its side [mm] (e.g. half a
            ply's thickness); 0: on the surface.
    """

    start: tuple[float, float, float]
    spacing: float
    nodes: tuple[int, int] = (24, 24)
    angle: float = 0.0
    origin: tuple[int, int] | None = None
    side: int = 1
    clearance: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", finite_point("start", self.start))
        if not (isinstance(self.spacing, int | float) and math.isfinite(self.spacing)
                and self.spacing > 0):
            raise InputError("spacing", f"must be a positive length [mm], got {self.spacing!r}")
        if (len(self.nodes) != 2 or not all(isinstance(n, int | np.integer) for n in self.nodes)
                or min(self.nodes) < 2):
            raise InputError("nodes", f"must be two integers >= 2, got {self.nodes!r}")
        if not math.isfinite(self.angle):
            raise InputError("angle", f"must be a finite angle [deg], got {self.angle!r}")
        object.__setattr__(self, "nodes", tuple(int(n) for n in self.nodes))
        if self.origin is None:
            object.__setattr__(self, "origin", tuple((n - 1) // 2 for n in self.nodes))
        o = self.origin
        if (len(o) != 2 or not all(isinstance(k, int | np.integer) for k in o)
                or not all(0 <= o[k] <= self.nodes[k] - 2 for k in (0, 1))):
            raise InputError("origin", f"must lie in [0, rows - 2] x [0, columns - 2] = "
                             f"[0, {self.nodes[0] - 2}] x [0, {self.nodes[1] - 2}], got {o!r}")
        object.__setattr__(self, "origin", tuple(int(k) for k in o))
        if self.side not in (-1, 1):
            raise InputError("side", f"must be +1 (outside the tool) or -1, got {self.side!r}")
        if not (math.isfinite(self.clearance) and self.clearance >= 0):
            raise InputError("clearance", f"must be >= 0 [mm], got {self.clearance!r}")


@dataclass(frozen=True, eq=False)
class Drape:
    """A draped net and its shear angles (NaN where the net could not be placed).

    Attributes:
        settings: The settings it was made with.
        nodes: Node positions (rows, columns, 3) [mm].
        corner_shear: Shear at the corners of each cell (rows - 1, columns - 1, 4) [deg],
            corners (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1) of cell (i, j).
        cell_shear: Mean of the corners (rows - 1, columns - 1) [deg].
        node_shear: Shear between the fibre tangents at each node (rows, columns) [deg]:
            central differences, one-sided at the net's edge.
        cell_area: Area of each cell (rows - 1, columns - 1) [mm^2].
        failures: Why nodes were not placed: reason -> count (dependants not counted).
    """

    settings: DrapeSettings
    nodes: np.ndarray
    corner_shear: np.ndarray
    cell_shear: np.ndarray
    node_shear: np.ndarray
    cell_area: np.ndarray
    failures: dict = field(default_factory=dict)

    @property
    def placed(self) -> int:
        """Number of nodes placed."""
        return int(np.isfinite(self.nodes[..., 0]).sum())

    def shear_range(self) -> tuple[float, float]:
        """Smallest and largest cell shear [deg] (NaN if no cell was placed)."""
        s = self.cell_shear[np.isfinite(self.cell_shear)]
        return (float(s.min()), float(s.max())) if s.size else (math.nan, math.nan)

    def area_fraction_beyond(self, limits: tuple[float, float] = (42.0, -50.0)) -> float:
        """Area fraction of the placed cells sheared beyond ``(positive, negative)`` limits."""
        ok = np.isfinite(self.cell_shear)
        a, s = self.cell_area[ok], self.cell_shear[ok]
        total = a.sum()
        return float(a[(s > limits[0]) | (s < limits[1])].sum() / total) if total else math.nan

    def flat_nodes(self) -> np.ndarray:
        """The net before draping, (rows, columns, 2) [mm].

        A square grid in plan view through the start, the first family at ``angle``, the
        second at ``angle + 90``.
        """
        st = self.settings
        i, j = np.meshgrid(np.arange(st.nodes[0]) - st.origin[0],
                           np.arange(st.nodes[1]) - st.origin[1], indexing="ij")
        a = math.radians(st.angle)
        e1, e2 = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        return (np.asarray(st.start[:2]) + st.spacing * (i[..., None] * e1
                                                          + j[..., None] * e2))


@dataclass(frozen=True)
class _Sided:
    """The surface seen from the net's side, moved off it by the clearance."""

    surface: Surface
    side: int
    clearance: float

    def evaluate(self, points):
        f, g = self.surface.evaluate(points)
        return self.side * f - self.clearance, self.side * g

    def contains(self, points):
        return self.surface.contains(points)


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle between vectors (..., 3) [rad], accurate near 0 and pi."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def quad_corner_shear(q: np.ndarray) -> np.ndarray:
    """Signed corner shears [rad] of cells q (..., 4, 3).

    The corners are in the order (i, j), (i+1, j), (i+1, j+1), (i, j+1); each shear is
    ``pi/2`` minus the angle between the cell's +i and +j edges at that corner.
    """
    ei = (q[..., 1, :] - q[..., 0, :], q[..., 1, :] - q[..., 0, :],
          q[..., 2, :] - q[..., 3, :], q[..., 2, :] - q[..., 3, :])
    ej = (q[..., 3, :] - q[..., 0, :], q[..., 2, :] - q[..., 1, :],
          q[..., 2, :] - q[..., 1, :], q[..., 3, :] - q[..., 0, :])
    return np.stack([np.pi / 2 - _angle(a, b) for a, b in zip(ei, ej, strict=True)], axis=-1)


def _solve_node(surface: Surface, a, d, guess, b=None, w=None):
    """The point p with |p - a| = d, f(p) = 0 and either |p - b| = d or (p - a).w = 0.

    Newton from ``guess``, steps limited to d/2. Returns None without convergence.
    """
    p = np.array(guess, dtype=float)
    tol = _TOL * d
    for _ in range(_MAX_ITER):
        f, g = surface.evaluate(p[None])
        ra = p - a
        la = np.linalg.norm(ra)
        if b is not None:
            rb = p - b
            lb = np.linalg.norm(rb)
            second, row = lb - d, rb / lb
        else:
            second, row = ra @ w, w
        r = np.array([la - d, second, f[0]])
        J = np.vstack([ra / la, row, g[0]])
        try:
            dp = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            return None
        n = np.linalg.norm(dp)
        if n > d / 2:
            dp *= d / 2 / n
        p = p + dp
        if np.abs(r).max() < tol and n < 1e3 * tol:
            return p
    return None


def _tangent(g: np.ndarray, u: np.ndarray) -> np.ndarray | None:
    """Unit tangent at a point with normal g that runs along plan direction u."""
    n = g / np.linalg.norm(g)
    t = np.sign(n[2]) * (n[2] * u - (n @ u) * np.array([0.0, 0.0, 1.0]))
    return None if abs(n[2]) < 1e-3 else t / np.linalg.norm(t)


def _quad(lo: tuple[int, int]) -> list[tuple[int, int]]:
    """Node indices of the cell whose lowest node is ``lo``, in corner order."""
    i, j = lo
    return [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]


class _Net:
    """The net under construction: node positions and the failures met."""

    def __init__(self, surface: Surface, st: DrapeSettings):
        self.s, self.st, self.d = surface, st, float(st.spacing)
        self.p = np.full((*st.nodes, 3), np.nan)
        self.failures: dict[str, int] = {}
        self.orientation = 0.0

    def fail(self, reason: str) -> None:
        self.failures[reason] = self.failures.get(reason, 0) + 1

    def known(self, *idx) -> bool:
        return all(np.isfinite(self.p[k][0]) for k in idx)

    def accept(self, quad_idx, new: dict) -> bool:
        """Check new nodes (on the extent, cell not folded) and store them."""
        if not self.s.contains(np.array(list(new.values()))).all():
            self.fail("off the surface's extent")
            return False
        q = np.array([new[k] if k in new else self.p[k] for k in quad_idx])
        normal = np.cross(q[2] - q[0], q[3] - q[1])
        g = self.s.evaluate(q.mean(axis=0)[None])[1][0]
        side = normal @ g / (np.linalg.norm(normal) * np.linalg.norm(g) + 1e-300)
        if self.orientation == 0.0:
            self.orientation = math.copysign(1.0, side)
        if side * self.orientation < 1e-6:
            self.fail("cell folded (shear reached 90 deg)")
            return False
        for k, x in new.items():
            self.p[k] = x
        return True

    def first_edge(self) -> None:
        i0, j0 = self.st.origin
        p0 = self.p[i0, j0]
        g = self.s.evaluate(p0[None])[1][0]
        a = math.radians(self.st.angle + 90.0)
        u = np.array([math.cos(a), math.sin(a), 0.0])
        t = _tangent(g, u)
        if t is None:
            raise InputError("start", "the surface is vertical at the start point; the fibre "
                             "angle is given in plan view: start where the surface is not")
        p1 = _solve_node(self.s, p0, self.d, p0 + self.d * t, w=np.cross([0.0, 0.0, 1.0], u))
        if p1 is None or not self.s.contains(p1[None])[0]:
            raise InputError("start", f"no surface point at distance {self.d:g} mm from the "
                             f"start along the second family: start further from an edge")
        self.p[i0, j0 + 1] = p1

    def arm_cell(self, v1, v2, v4, v3, t0: np.ndarray) -> np.ndarray | None:
        """Place v4 and v3 of a generator cell with zero mean shear; t0 guesses v1 -> v4."""
        a, b = self.p[v1], self.p[v2]
        n = self.s.evaluate(a[None])[1][0]
        n = n / np.linalg.norm(n)
        b1 = t0 - (t0 @ n) * n
        b1 /= np.linalg.norm(b1)
        b2 = np.cross(n, b1)
        order = _quad(min(v1, v2, v3, v4))

        def cell(psi):
            t = math.cos(psi) * b1 + math.sin(psi) * b2
            p4 = _solve_node(self.s, a, self.d, a + self.d * t, w=np.cross(n, t))
            if p4 is None:
                return None
            p3 = _solve_node(self.s, b, self.d, b + p4 - a, b=p4)
            if p3 is None:
                return None
            pos = {v1: a, v2: b, v4: p4, v3: p3}
            return float(np.mean(quad_corner_shear(np.array([pos[k] for k in order])))), p4, p3

        psi, h = 0.0, 1e-6
        for _ in range(_MAX_ITER):
            c0, c1 = cell(psi), cell(psi + h)
            if c0 is None or c1 is None:
                break
            if abs(c0[0]) < _TOL:
                return c0[1:] if self.accept(order, {v4: c0[1], v3: c0[2]}) else None
            slope = (c1[0] - c0[0]) / h
            step = -c0[0] / slope if slope != 0 else 0.1
            psi += max(-0.3, min(0.3, step))
        self.fail("generator cell without a zero-shear position")
        return None

    def arms(self) -> None:
        """The four generator arms: +i (from the origin cell on), +j, -i, -j."""
        (i0, j0), (rows, cols) = self.st.origin, self.st.nodes
        for k, (di, dj) in enumerate(((1, 0), (0, 1), (-1, 0), (0, -1))):
            # the known edge (v1, v2) of each cell, across the arm
            if di:
                known = [((r, j0), (r, j0 + 1)) for r in (range(i0, rows - 1) if di > 0
                                                          else range(i0, 0, -1))]
            else:
                known = [((i0, c), (i0 + 1, c)) for c in (range(j0 + 1, cols - 1) if dj > 0
                                                          else range(j0, 0, -1))]
            a = math.radians(self.st.angle + 90.0 * k)
            plan = np.array([math.cos(a), math.sin(a), 0.0])
            for v1, v2 in known:
                v4, v3 = (v1[0] + di, v1[1] + dj), (v2[0] + di, v2[1] + dj)
                behind = (v1[0] - di, v1[1] - dj)
                if not self.known(v1, v2):
                    break
                if 0 <= behind[0] < rows and 0 <= behind[1] < cols and self.known(behind):
                    t0 = self.p[v1] - self.p[behind]  # straight on
                else:  # the origin cell: the plan-view direction of the arm
                    t0 = _tangent(self.s.evaluate(self.p[v1][None])[1][0], plan)
                if t0 is None or self.arm_cell(v1, v2, v4, v3, t0) is None:
                    break

    def quadrants(self) -> None:
        (i0, j0), (rows, cols) = self.st.origin, self.st.nodes
        for si in (1, -1):
            ii = range(i0 + 2, rows) if si > 0 else range(i0 - 1, -1, -1)
            for sj in (1, -1):
                jj = range(j0 + 2, cols) if sj > 0 else range(j0 - 1, -1, -1)
                for i in ii:
                    for j in jj:
                        a, b, c = (i - si, j), (i, j - sj), (i - si, j - sj)
                        if not self.known(a, b, c):
                            continue
                        pa, pb, pc = self.p[a], self.p[b], self.p[c]
                        if np.linalg.norm(pa - pb) >= 2 * self.d:
                            self.fail("neighbours more than two edges apart")
                            continue
                        x = _solve_node(self.s, pa, self.d, pa + pb - pc, b=pb)
                        if x is None:
                            self.fail("no surface point at one edge from both neighbours")
                            continue
                        self.accept(_quad((min(i, i - si), min(j, j - sj))), {(i, j): x})


def _node_shear(p: np.ndarray) -> np.ndarray:
    """Shear [deg] between the fibre tangents at each node (NaN-aware differences)."""

    def tangent(axis: int) -> np.ndarray:
        q = np.moveaxis(p, axis, 0)
        pad = np.full_like(q[:1], np.nan)
        fwd = np.concatenate([q[1:], pad]) - q
        bwd = q - np.concatenate([pad, q[:-1]])
        cen = (fwd + bwd) / 2
        t = np.where(np.isfinite(cen), cen, np.where(np.isfinite(fwd), fwd, bwd))
        return np.moveaxis(t, 0, axis)

    return np.degrees(np.pi / 2 - _angle(tangent(0), tangent(1)))


def chebyshev_sphere_shear(u: float, v: float, radius: float = 1.0, n: int = 400) -> float:
    """Shear [deg] of the continuous Chebyshev net on a sphere, the limit of the drape.

    The net's two families meet at the angle omega with ``omega_uv = -K sin(omega)``
    (Hazzidakis; K = 1/radius^2) in fabric coordinates (u, v) [mm] along the fibres. With
    two orthogonal geodesic generators through the origin, ``omega = pi/2`` on u = 0 and
    v = 0; the integral equation is solved by fixed-point iteration with the trapezoidal
    rule on an n x n grid (second order). Returns ``90 - omega`` at (u, v).
    """
    k = 1.0 / radius**2
    w = np.full((n + 1, n + 1), np.pi / 2)
    for _ in range(100):
        f = -k * np.sin(w)
        fu = np.cumsum((f[1:] + f[:-1]) / 2, axis=0) * (u / n)
        fu = np.vstack([np.zeros((1, n + 1)), fu])
        fuv = np.cumsum((fu[:, 1:] + fu[:, :-1]) / 2, axis=1) * (v / n)
        new = np.pi / 2 + np.hstack([np.zeros((n + 1, 1)), fuv])
        done = np.abs(new - w).max() < 1e-14
        w = new
        if done:
            break
    return float(np.degrees(np.pi / 2 - w[-1, -1]))


def drape(surface: Surface, settings: DrapeSettings) -> Drape:
    """Drape a pin-jointed net onto ``surface`` (module docstring: the construction).

    Raises:
        InputError: ``start`` farther than half a spacing from the surface, outside its
            extent, where it is vertical, or too near its edge for the first edge.
    """
    st = settings
    s = _Sided(surface, st.side, st.clearance)
    start = np.asarray(st.start)
    f0 = float(s.evaluate(start[None])[0][0])
    if not abs(f0) <= st.spacing / 2:
        raise InputError("start", f"{st.start} is {f0:.4g} mm from the surface (more than half "
                         f"the spacing, {st.spacing / 2:g} mm): not a point on it")
    p0 = project(s, start)
    if not s.contains(p0[None])[0]:
        raise InputError("start", f"{st.start} lies outside the surface's extent")
    net = _Net(s, st)
    net.p[st.origin] = p0
    net.first_edge()
    net.arms()
    net.quadrants()
    p = net.p
    quads = np.stack([p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]], axis=2)
    corner = np.degrees(quad_corner_shear(quads))
    area = 0.5 * np.linalg.norm(np.cross(quads[:, :, 2] - quads[:, :, 0],
                                         quads[:, :, 3] - quads[:, :, 1]), axis=-1)
    return Drape(st, p, corner, corner.mean(axis=2), _node_shear(p), area, net.failures)
