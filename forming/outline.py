"""Blank outlines in the x-y plane: polygons and closed splines, validated when built."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from forming.errors import InputError


def check_positive(fname: str, v) -> float:
    """``v`` as a float; an :class:`InputError` naming ``fname`` unless positive and finite."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise InputError(fname, f"must be a number, got {v!r}")
    if not math.isfinite(v) or v <= 0:
        raise InputError(fname, f"must be a positive finite number, got {v!r}")
    return float(v)


def check_integer(fname: str, v, minimum: int) -> int:
    """``v`` as an int; an :class:`InputError` naming ``fname`` unless an integer >= minimum."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
        raise InputError(fname, f"must be an integer >= {minimum}, got {v!r}")
    return int(v)


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _on_segment(a: np.ndarray, b: np.ndarray, p: np.ndarray, tol: float) -> bool:
    lo, hi = np.minimum(a, b) - tol, np.maximum(a, b) + tol
    return bool(np.all(p >= lo) and np.all(p <= hi))


def _segments_touch(p1, p2, q1, q2, eps: float, tol: float) -> bool:
    """Whether the closed segments p1-p2 and q1-q2 share a point."""
    d1 = _cross(q2 - q1, p1 - q1)
    d2 = _cross(q2 - q1, p2 - q1)
    d3 = _cross(p2 - p1, q1 - p1)
    d4 = _cross(p2 - p1, q2 - p1)
    if ((d1 > eps and d2 < -eps) or (d1 < -eps and d2 > eps)) and (
        (d3 > eps and d4 < -eps) or (d3 < -eps and d4 > eps)
    ):
        return True
    return (
        (abs(d1) <= eps and _on_segment(q1, q2, p1, tol))
        or (abs(d2) <= eps and _on_segment(q1, q2, p2, tol))
        or (abs(d3) <= eps and _on_segment(p1, p2, q1, tol))
        or (abs(d4) <= eps and _on_segment(p1, p2, q2, tol))
    )


def _first_crossing(pts: np.ndarray, rel: float) -> tuple[int, int] | None:
    """First pair of edges (i, j) of the closed polygon that cross or overlap.

    ``rel`` is the tolerance relative to the polygon's size.
    """
    n = len(pts)
    scale = float(np.ptp(pts, axis=0).max())
    tol, eps = rel * scale, rel * scale**2
    edges = [(pts[i], pts[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        # Adjacent edges share a vertex; they are bad only when they fold back.
        a = edges[i][1] - edges[i][0]
        b = edges[(i + 1) % n][1] - edges[(i + 1) % n][0]
        if abs(_cross(a, b)) <= eps and float(a @ b) < 0.0:
            return i, (i + 1) % n
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            if _segments_touch(*edges[i], *edges[j], eps, tol):
                return i, j
    return None


def _signed_area(pts: np.ndarray) -> float:
    x, y = pts[:, 0], pts[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


@dataclass(frozen=True)
class Outline:
    """Closed blank outline in the x-y plane.

    A polygon (straight edges between the points) or a closed spline through the
    points (gmsh's interpolating ``Spline``). The points are validated and stored
    counter-clockwise; a last point equal to the first is dropped.

    Attributes:
        points: Corner (polygon) or through (spline) points (x, y) [mm], at least 3.
        kind: ``"polygon"`` or ``"spline"``.

    Raises:
        InputError: Fewer than 3 points, non-finite or repeated consecutive points,
            a self-intersecting polygon (for a spline: control polygon), zero area.
    """

    points: tuple[tuple[float, float], ...]
    kind: Literal["polygon", "spline"] = "polygon"

    def __post_init__(self) -> None:
        field_ = "mesh.outline.points"
        if self.kind not in ("polygon", "spline"):
            raise InputError(
                "mesh.outline.kind", f"must be 'polygon' or 'spline', got {self.kind!r}"
            )
        try:
            pts = np.array(self.points, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(field_, f"must be a sequence of (x, y) pairs: {exc}") from exc
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise InputError(field_, f"must be a sequence of (x, y) pairs, got shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise InputError(field_, "all coordinates must be finite")
        if len(pts) > 3 and np.array_equal(pts[0], pts[-1]):
            pts = pts[:-1]  # explicitly closed outline
        if len(pts) < 3:
            raise InputError(field_, f"a closed outline needs at least 3 points, got {len(pts)}")
        scale = float(np.ptp(pts, axis=0).max())
        tol = 1e-9 * scale
        gaps = np.linalg.norm(pts - np.roll(pts, -1, axis=0), axis=1)
        if scale == 0.0 or np.any(gaps <= tol):
            i = int(np.argmin(gaps))
            raise InputError(
                field_, f"points {i} and {(i + 1) % len(pts)} coincide ({pts[i].tolist()})"
            )
        crossing = _first_crossing(pts, 1e-9)
        if crossing is not None:
            i, j = crossing
            what = "polygon" if self.kind == "polygon" else "control polygon of the spline"
            raise InputError(
                field_, f"the {what} intersects itself: edges {i} and {j} cross or overlap"
            )
        area = _signed_area(pts)
        if abs(area) <= 1e-9 * scale**2:
            raise InputError(field_, "the outline encloses no area")
        if area < 0.0:  # clockwise: reverse, keeping the first point first
            pts = np.concatenate([pts[:1], pts[:0:-1]])
        object.__setattr__(self, "points", tuple((float(x), float(y)) for x, y in pts))

    @classmethod
    def rectangle(
        cls, lx: float, ly: float, origin: tuple[float, float] = (0.0, 0.0)
    ) -> Outline:
        """Axis-aligned rectangle ``lx`` x ``ly`` [mm] with its lower-left corner at ``origin``.

        Raises:
            InputError: A side is not a positive finite number.
        """
        lx = check_positive("mesh.outline.lx", lx)
        ly = check_positive("mesh.outline.ly", ly)
        x0, y0 = float(origin[0]), float(origin[1])
        return cls(((x0, y0), (x0 + lx, y0), (x0 + lx, y0 + ly), (x0, y0 + ly)))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the points [mm]."""
        p = np.asarray(self.points)
        return (*(float(v) for v in p.min(axis=0)), *(float(v) for v in p.max(axis=0)))

    @property
    def polygon_area(self) -> float:
        """Area of the polygon through the points [mm^2] (for a spline: an approximation)."""
        return _signed_area(np.asarray(self.points))

    @property
    def is_convex_quadrilateral(self) -> bool:
        """Whether the outline is a convex 4-corner polygon (it can be meshed structured)."""
        if self.kind != "polygon" or len(self.points) != 4:
            return False
        p = np.asarray(self.points)
        turns = [_cross(p[(i + 1) % 4] - p[i], p[(i + 2) % 4] - p[(i + 1) % 4]) for i in range(4)]
        return all(t > 0 for t in turns)
