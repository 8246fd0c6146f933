"""Rigid tool shapes as signed distance functions (positive outside the tool).

Each shape writes its distance once, for a "backend" that is either UFL (contact
terms, differentiated by UFL) or NumPy (outputs, rendering, tests). Points are
3-component sequences: a UFL vector or a (3, n) array.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import ClassVar

import numpy as np
import ufl

from forming.contact import nodalkernels
from forming.errors import InputError

UFL = SimpleNamespace(sqrt=ufl.sqrt, max=ufl.max_value, min=ufl.min_value)
NUMPY = SimpleNamespace(sqrt=np.sqrt, max=np.maximum, min=np.minimum)

# Keeps square roots differentiable where a distance vanishes (1e-6 mm).
_EPS2 = 1e-12


def _positive(field: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise InputError(field, f"must be a positive number, got {value!r}")


def _norm3(xp, a, b, c):
    return xp.sqrt(a * a + b * b + c * c + _EPS2)


_H = 1e-6  # difference step of the normal [mm]


class AnalyticShape:
    """What every analytic shape shares: a UFL distance, a normal by differences."""

    tracked: ClassVar[bool] = False  # the distance is a UFL expression
    search_seconds: ClassVar[float] = 0.0  # no closest-point search

    def gap_normal(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) and outward normal (n, 3) of the (n, 3) points.

        The normal is a one-sided difference of the distance with a step of 1e-6 mm.
        """
        n = len(points)
        pts = np.tile(np.asarray(points, dtype=float).T, 4)
        for k in range(3):
            pts[k, (k + 1) * n:(k + 2) * n] += _H
        d = np.broadcast_to(np.asarray(self.distance(pts, NUMPY), dtype=float), (4 * n,))
        grad = (d[n:].reshape(3, n) - d[:n]) / _H
        normal = (grad / np.sqrt(np.sum(grad * grad, axis=0) + 1e-30)).T
        return d[:n].copy(), normal

    def check_units(self, extent: float) -> None:
        """Nothing to check: an analytic shape is given in mm."""

    def tracker(self) -> AnalyticShape:
        """Itself: a formula has nothing to track (see ``SurfaceTool.tracker``)."""
        return self

    def repair(self) -> None:
        """Nothing to search again."""

    def kernel_code(self) -> tuple[int, np.ndarray]:
        """The shape's code and parameters in :mod:`forming.contact.nodalkernels`."""
        raise NotImplementedError


@dataclass(frozen=True)
class Plane(AnalyticShape):
    """Half-space tool ``n . (p - point) <= 0`` (a platen); ``normal`` points out of it."""

    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if np.linalg.norm(self.normal) == 0:
            raise InputError("tool.normal", "must be non-zero")

    def distance(self, p, xp):
        """Signed distance of points ``p``."""
        n = np.asarray(self.normal, dtype=float)
        n = n / np.linalg.norm(n)
        return sum(n[i] * (p[i] - self.point[i]) for i in range(3))

    def kernel_code(self) -> tuple[int, np.ndarray]:
        """Code and parameters: the unit normal, the point."""
        n = np.asarray(self.normal, dtype=float)
        return nodalkernels.PLANE, np.concatenate([n / np.linalg.norm(n), self.point])


@dataclass(frozen=True)
class HemisphericalPunch(AnalyticShape):
    """A cylinder of ``radius`` with a hemispherical end (a capsule), axis along z.

    Attributes:
        tip: Lowest point of the hemisphere (``direction=-1``) or highest (``+1``).
        radius: Punch radius [mm].
        length: Length of the cylindrical shank above the hemisphere [mm].
        direction: -1 when the punch points down (moves towards -z), +1 when up.
    """

    tip: tuple[float, float, float]
    radius: float
    length: float = 200.0
    direction: int = -1

    def __post_init__(self) -> None:
        _positive("tool.radius", self.radius)
        _positive("tool.length", self.length)
        if self.direction not in (-1, 1):
            raise InputError("tool.direction", "must be -1 or +1")

    def distance(self, p, xp):
        """Signed distance of points ``p``."""
        s = -self.direction  # the segment runs from the sphere centre away from the tip
        zc = self.tip[2] + s * self.radius
        t = xp.min(xp.max(s * (p[2] - zc), 0.0), self.length)
        return _norm3(xp, p[0] - self.tip[0], p[1] - self.tip[1], p[2] - (zc + s * t)) - \
            self.radius

    def kernel_code(self) -> tuple[int, np.ndarray]:
        """Code and parameters: the tip, radius, length, minus the direction."""
        return nodalkernels.PUNCH, np.array([*self.tip, self.radius, self.length,
                                             -self.direction], dtype=float)


@dataclass(frozen=True)
class Roller(AnalyticShape):
    """An infinitely long cylinder (a bending-test roller), axis along y.

    Attributes:
        center: A point on the axis.
        radius: Roller radius [mm].
    """

    center: tuple[float, float, float]
    radius: float

    def __post_init__(self) -> None:
        _positive("tool.radius", self.radius)

    def distance(self, p, xp):
        """Signed distance of points ``p``."""
        return _norm3(xp, p[0] - self.center[0], 0.0 * p[1], p[2] - self.center[2]) - \
            self.radius

    def kernel_code(self) -> tuple[int, np.ndarray]:
        """Code and parameters: the axis' x and z, the radius."""
        return nodalkernels.ROLLER, np.array([self.center[0], self.center[2], self.radius],
                                             dtype=float)


@dataclass(frozen=True)
class RoundedBox(AnalyticShape):
    """A box with all edges rounded (the square punch with filleted edges).

    Attributes:
        center: Centre of the box.
        half_size: Half edge lengths (x, y, z) [mm]; each at least ``radius``.
        radius: Edge fillet radius [mm].
    """

    center: tuple[float, float, float]
    half_size: tuple[float, float, float]
    radius: float

    def __post_init__(self) -> None:
        _positive("tool.radius", self.radius)
        if any(h < self.radius for h in self.half_size):
            raise InputError("tool.half_size", "every half size must be >= the fillet radius")

    def distance(self, p, xp):
        """Signed distance of points ``p``."""
        q = [xp.max(p[i] - self.center[i], self.center[i] - p[i]) - (self.half_size[i]
                                                                         - self.radius)
             for i in range(3)]
        outside = _norm3(xp, xp.max(q[0], 0.0), xp.max(q[1], 0.0), xp.max(q[2], 0.0))
        inside = xp.min(xp.max(q[0], xp.max(q[1], q[2])), 0.0)
        return outside + inside - self.radius

    def kernel_code(self) -> tuple[int, np.ndarray]:
        """Code and parameters: the centre, the half sizes, the radius."""
        return nodalkernels.BOX, np.array([*self.center, *self.half_size, self.radius],
                                          dtype=float)


@dataclass(frozen=True)
class AnnularPlate(AnalyticShape):
    """A plate with a rounded circular opening (a die, or a blank holder).

    The opening's axis is the z-axis through ``center``.

    Attributes:
        center: Point on the working face, on the opening's axis.
        hole_radius: Radius of the opening at the working face's level, where the fillet
            ends [mm]; the opening's wall is at this radius.
        edge_radius: Fillet radius of the opening's edge [mm].
        side: -1 for a die (solid below its face), +1 for a blank holder (solid above).
        thickness: Plate thickness [mm].
    """

    center: tuple[float, float, float]
    hole_radius: float
    edge_radius: float
    side: int = -1
    thickness: float = 50.0

    def __post_init__(self) -> None:
        _positive("tool.hole_radius", self.hole_radius)
        _positive("tool.edge_radius", self.edge_radius)
        _positive("tool.thickness", self.thickness)
        if self.side not in (-1, 1):
            raise InputError("tool.side", "must be -1 (die) or +1 (blank holder)")

    def distance(self, p, xp):
        """Signed distance of points ``p`` (2D rounded-corner distance in (radius, depth))."""
        r = self.edge_radius
        rho = xp.sqrt((p[0] - self.center[0]) ** 2 + (p[1] - self.center[1]) ** 2 + _EPS2)
        depth = self.side * (p[2] - self.center[2])  # > 0 inside the plate's slab
        a = rho - (self.hole_radius + r)  # >= 0 beyond the inset corner
        b = depth - r  # >= 0 inside the inset slab
        c = (self.thickness - r) - depth  # back face
        m = xp.min(b, c)
        outside = xp.sqrt(xp.max(-a, 0.0) ** 2 + xp.max(-m, 0.0) ** 2 + _EPS2)
        inside = xp.min(xp.max(-a, -m), 0.0)
        return outside + inside - r

    def kernel_code(self) -> tuple[int, np.ndarray]:
        """Code and parameters: the centre, hole and edge radii, side, thickness."""
        return nodalkernels.ANNULAR, np.array([*self.center, self.hole_radius,
                                               self.edge_radius, self.side, self.thickness],
                                              dtype=float)


Shape = Plane | HemisphericalPunch | Roller | RoundedBox | AnnularPlate
"""The analytic shapes; a tool may also be a :class:`~forming.contact.surface.SurfaceTool`."""
