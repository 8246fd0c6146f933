"""Surfaces a net can be draped onto: what the construction needs, and tool shapes.

The kinematic drape (:mod:`forming.drape`) uses a surface only through two methods:
``evaluate(points) -> (distance, gradient)`` and ``contains(points)``.
:class:`ShapeSurface` gives them for the signed-distance tool shapes of
:mod:`forming.contact.shapes` (gradients by central differences); a triangulated surface
(an STL of a tool) can implement the same two (distance to the nearest facet, signed by
its normal; contained when the nearest point is not on the boundary).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from forming.contact.shapes import NUMPY
from forming.errors import InputError

_TOL = 1e-12


def finite_point(field_name: str, value) -> tuple[float, float, float]:
    """``value`` as three finite floats, or an InputError naming ``field_name``."""
    v = tuple(float(x) for x in value)
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise InputError(field_name, f"must be three finite numbers, got {value!r}")
    return v


class Surface(Protocol):
    """What the construction needs from a surface (positive distance: the net's side)."""

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances (n,) and their gradients (n, 3) at points (n, 3) [mm]."""
        ...

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether points (n, 3) on the surface lie within its extent (n,) bool."""
        ...


@dataclass(frozen=True)
class ShapeSurface:
    """The surface of a signed-distance tool shape (:mod:`forming.contact.shapes`).

    Attributes:
        shape: A shape with ``distance(p, NUMPY)`` for p of shape (3, n), positive outside.
        shift: Translation of the shape [mm] (a tool's ``offset(t)``).
        bounds: Lower and upper corners of the box the surface ends at [mm] (``inf``
            allowed); None: the whole surface. A node outside it is not placed.
    """

    shape: object
    shift: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None

    def __post_init__(self) -> None:
        if not callable(getattr(self.shape, "distance", None)):
            raise InputError("surface.shape", f"{self.shape!r} has no distance(p, xp)")
        object.__setattr__(self, "shift", finite_point("surface.shift", self.shift))
        if self.bounds is not None:
            lo, hi = (np.asarray(b, dtype=float) for b in self.bounds)
            if lo.shape != (3,) or hi.shape != (3,) or np.isnan(lo).any() or np.any(lo >= hi):
                raise InputError("surface.bounds",
                                 f"must be two corners (3 numbers each), lower < upper, "
                                 f"got {self.bounds!r}")

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distances of points (n, 3) [mm]."""
        p = (np.asarray(points, dtype=float) - np.asarray(self.shift)).T
        return np.asarray(self.shape.distance(p, NUMPY), dtype=float) * np.ones(p.shape[1])

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances and central-difference gradients at points (n, 3)."""
        p = np.asarray(points, dtype=float)
        h = 1e-6 * max(1.0, float(np.abs(p).max()))
        steps = np.vstack([np.zeros(3), h * np.eye(3), -h * np.eye(3)])
        f = self.distance((p[:, None, :] + steps[None]).reshape(-1, 3)).reshape(len(p), 7)
        return f[:, 0], (f[:, 1:4] - f[:, 4:7]) / (2 * h)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether points (n, 3) lie within ``bounds``."""
        p = np.asarray(points, dtype=float)
        if self.bounds is None:
            return np.isfinite(p).all(axis=1)
        lo, hi = (np.asarray(b, dtype=float) for b in self.bounds)
        return np.all((p >= lo) & (p <= hi), axis=1)


def project(surface: Surface, point, iterations: int = 50) -> np.ndarray:
    """The point of ``surface`` closest to ``point`` (steepest descent on the distance)."""
    p = np.asarray(point, dtype=float).reshape(1, 3)
    for _ in range(iterations):
        f, g = surface.evaluate(p)
        p = p - f[0] * g / max(float(np.sum(g * g)), 1e-30)
        if abs(f[0]) < _TOL * max(1.0, float(np.abs(p).max())):
            break
    return p[0]
