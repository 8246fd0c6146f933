"""Net-shape blank development: trim line mapped back to the flat blank, run after run.

After a forming run, ``forming_map.npz`` (:class:`~forming.demonstrator.report.Report`)
holds the core's mid-surface (halfway between its top and bottom faces) before and
after forming. Split into triangles and mirrored into the whole part, it defines the
forming map X -> x in plan and its inverse: a trim point p lies in a formed triangle,
and the same barycentric weights in the flat triangle give the material point that
ends at p (outside the formed blank, the nearest triangle's affine map extrapolates).
The trim line, resampled every ``SPACING``, mapped back and offset outward by the
margin, becomes the next blank: a closed centripetal Catmull-Rom spline sampled
densely. The run repeats until the formed edge lies within the tolerance of the trim
line everywhere: the largest plan distance to the trim line of every node of the core's
edge, top, middle and bottom (the trim line lies on the part's flange, where plan and
surface distances agree). Skin-core slip shears the edge (its top and bottom end a
millimetre or two apart in plan); mapping the mid-surface makes it straddle the trim
line.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forming.demonstrator.curves import distance_to_polyline
from forming.demonstrator.geometry import COPIES
from forming.errors import InputError

SPACING = 10.0  # trim line resampling before the back-mapping [mm]
SAMPLES = 8  # points per spline segment of the new outline


@dataclass(frozen=True)
class FormingMap:
    """The forming map of a run in plan, whole part (mirrored from the quarter).

    Attributes:
        flat: Triangles in the flat blank (m, 3, 2) [mm].
        formed: The same triangles after forming (m, 3, 2) [mm].
        edge: Formed blank edge nodes in plan (k, 2) [mm] (quarter).
        trim: The trim line (n, 2) [mm].
        blank: The blank outline the run formed (b, 2) [mm].
    """

    flat: np.ndarray
    formed: np.ndarray
    edge: np.ndarray
    trim: np.ndarray
    blank: np.ndarray

    @classmethod
    def read(cls, folder: Path) -> FormingMap:
        """The map of a finished run (its ``forming_map.npz``)."""
        from forming.demonstrator.report import FORMING_MAP

        path = Path(folder) / FORMING_MAP
        if not path.is_file():
            raise InputError("run", f"{path}: no forming map (did the run finish?)")
        d = np.load(path)
        flat = _triangles(d["reference"][:, :, :2])
        formed = _triangles(d["current"][:, :, :2])
        mirror = [np.asarray(c) for c in COPIES]
        # the edge's nodes (the face corners): the mesh's outline passes through them,
        # where face centres sit a chord's sagitta inside a rounded corner
        edge = np.unique(d["edge_current"][:, :, :2].reshape(-1, 2), axis=0)
        return cls(np.concatenate([flat * c for c in mirror]),
                   np.concatenate([formed * c for c in mirror]), edge, d["trim"], d["blank"])

    def back(self, points: np.ndarray) -> np.ndarray:
        """The flat-blank points (n, 2) that form to the plan points (n, 2)."""
        p = np.asarray(points, dtype=float)
        w = _barycentric(self.formed, p)  # (n, m, 3)
        worst = w.min(axis=2)  # >= 0 inside a triangle
        best = np.argmax(worst, axis=1)
        weights = w[np.arange(len(p)), best]
        return np.einsum("nk,nkd->nd", weights, self.flat[best])

    def deviation(self) -> np.ndarray:
        """Plan distance of each formed edge point to the trim line [mm]."""
        return distance_to_polyline(self.edge, self.trim)


def _triangles(quads: np.ndarray) -> np.ndarray:
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def _barycentric(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Barycentric weights (n, m, 3) of points p (n, 2) in triangles (m, 3, 2)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    d = p[:, None, :] - a[None]
    l1 = (d[..., 0] * v1[:, 1] - d[..., 1] * v1[:, 0]) / det
    l2 = (v0[:, 0] * d[..., 1] - v0[:, 1] * d[..., 0]) / det
    return np.stack([1.0 - l1 - l2, l1, l2], axis=2)


def resample(closed: np.ndarray, spacing: float = SPACING) -> np.ndarray:
    """Points every ``spacing`` (about) along a closed polyline, its corners kept out."""
    pts = np.vstack([closed, closed[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    n = max(8, int(np.ceil(s[-1] / spacing)))
    u = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.column_stack([np.interp(u, s, pts[:, 0]), np.interp(u, s, pts[:, 1])])


def spline(points: np.ndarray, samples: int = SAMPLES) -> np.ndarray:
    """A closed centripetal Catmull-Rom spline through the points, sampled densely."""
    p = np.asarray(points, dtype=float)
    n = len(p)
    out = []
    for i in range(n):
        p0, p1, p2, p3 = p[i - 1], p[i], p[(i + 1) % n], p[(i + 2) % n]
        t0 = 0.0
        t1 = t0 + np.linalg.norm(p1 - p0) ** 0.5
        t2 = t1 + np.linalg.norm(p2 - p1) ** 0.5
        t3 = t2 + np.linalg.norm(p3 - p2) ** 0.5
        for t in np.linspace(t1, t2, samples, endpoint=False):
            a1 = ((t1 - t) * p0 + (t - t0) * p1) / (t1 - t0)
            a2 = ((t2 - t) * p1 + (t - t1) * p2) / (t2 - t1)
            a3 = ((t3 - t) * p2 + (t - t2) * p3) / (t3 - t2)
            b1 = ((t2 - t) * a1 + (t - t0) * a2) / (t2 - t0)
            b2 = ((t3 - t) * a2 + (t - t1) * a3) / (t3 - t1)
            out.append(((t2 - t) * b1 + (t - t1) * b2) / (t2 - t1))
    return np.asarray(out)


def next_blank(fmap: FormingMap, margin: float = 0.0) -> np.ndarray:
    """The blank outline (dense, counter-clockwise) whose edge should form to the trim."""
    trim = resample(fmap.trim)
    flat = fmap.back(trim)
    if margin:
        tangent = np.roll(flat, -1, axis=0) - np.roll(flat, 1, axis=0)
        normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])  # outward (ccw curve)
        flat = flat + margin * normal / np.linalg.norm(normal, axis=1)[:, None]
    # enforce the part's symmetry against round-off: average the four mirror images
    outline = spline(flat)
    return symmetrise(outline)


def symmetrise(outline: np.ndarray) -> np.ndarray:
    """The outline's radius averaged with its mirror images' (sampled by angle)."""
    angle = np.arctan2(outline[:, 1], outline[:, 0])
    radius = np.hypot(outline[:, 0], outline[:, 1])
    order = np.argsort(angle)
    a, r = angle[order], radius[order]
    a = np.concatenate([a - 2 * np.pi, a, a + 2 * np.pi])
    r = np.tile(r, 3)
    grid = np.linspace(-np.pi, np.pi, len(outline), endpoint=False)
    mirrored = [np.interp(g, a, r) for g in (grid, np.pi - grid, -grid, grid + np.pi)]
    rho = np.mean(mirrored, axis=0)
    return np.column_stack([rho * np.cos(grid), rho * np.sin(grid)])
