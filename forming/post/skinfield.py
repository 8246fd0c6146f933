"""A skin's shear field from different models, compared material point by material point.

A fabric's shear belongs to its material points, so two models are compared at the same
points of the flat blank: a finite-element run's cell-centre shear (``final_shape.npz``,
``<body>_cell_*``) at the reference centroids of its cells, and a kinematic drape's node
shear (``drape.npz``) at the flat net's nodes, the pin-jointed net being inextensible
along its fibres. Each field is interpolated bilinearly onto the points of another:

- a run's cell centres on a regular grid in plan (a uniform skin mesh): bilinear between
  the centres, held constant over the half cell between the outer centres and the edge;
- a run's cell centres anywhere else (an unstructured skin mesh): linear over the
  Delaunay triangles of the centres (matplotlib's), the nearest centre's value outside
  them up to one centre spacing away (the rim of half cells along the edge), NaN beyond;
- a drape's net: bilinear between its placed nodes, NaN outside them (a drape covers the
  tool's surface only).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forming.errors import InputError


def _load(path: Path, keys: list[str]) -> dict[str, np.ndarray]:
    try:
        with np.load(path) as z:
            missing = [k for k in keys if k not in z.files]
            if missing:
                raise InputError(str(path), f"has no {missing} (a run from before cell-wise "
                                 "results were written, or no such body)")
            return {k: z[k] for k in keys}
    except OSError as exc:
        raise InputError(str(path), f"cannot be read: {exc}") from exc


def bilinear(values: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``values`` (n, m) at fractional grid indices (a, b); NaN outside the grid.

    A NaN corner makes the point NaN.
    """
    n, m = values.shape
    out = np.full(a.shape, np.nan)
    inside = (a >= 0) & (a <= n - 1) & (b >= 0) & (b <= m - 1)
    a, b = a[inside], b[inside]
    i = np.minimum(np.floor(a).astype(int), n - 2)
    j = np.minimum(np.floor(b).astype(int), m - 2)
    s, t = a - i, b - j
    out[inside] = ((1 - s) * (1 - t) * values[i, j] + s * (1 - t) * values[i + 1, j]
                   + s * t * values[i + 1, j + 1] + (1 - s) * t * values[i, j + 1])
    return out


@dataclass(frozen=True)
class CellField:
    """A body's cell-wise field at the end of a run.

    Attributes:
        X: Reference centroids (m, 3) [mm].
        x: Current centroids (m, 3) [mm].
        volume: Reference volumes (m,) [mm^3].
        values: The field (m,).
    """

    X: np.ndarray
    x: np.ndarray
    volume: np.ndarray
    values: np.ndarray

    @classmethod
    def load(cls, run: Path, body: str, field: str = "shear_angle_deg") -> CellField:
        """From a run's ``final_shape.npz``.

        Raises:
            InputError: No such file, body or field (named).
        """
        keys = [f"{body}_cell_{k}" for k in ("X", "x", "volume", field)]
        z = _load(Path(run) / "final_shape.npz", keys)
        return cls(*(z[k] for k in keys))

    def _grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The centres' distinct x and y and the values on that grid.

        None when the centres are not a regular grid in plan (graded or unstructured).
        """
        xs, ix = np.unique(np.round(self.X[:, 0], 6), return_inverse=True)
        ys, iy = np.unique(np.round(self.X[:, 1], 6), return_inverse=True)
        grid = np.full((xs.size, ys.size), np.nan)
        grid[ix, iy] = self.values
        regular = all(v.size < 3 or np.ptp(np.diff(v)) < 1e-6 * np.ptp(v) for v in (xs, ys))
        if (xs.size * ys.size != self.values.size or np.isnan(grid).any() or not regular
                or min(xs.size, ys.size) < 2):
            return None
        return xs, ys, grid

    def at(self, points: np.ndarray) -> np.ndarray:
        """The field at reference points (k, 2 or 3).

        On a regular grid of centres: bilinear between them; points between the outer
        centres and the blank's edge take the nearest centres' values (clamped); points
        beyond half a cell outside are NaN. Otherwise: :meth:`scattered`.
        """
        regular = self._grid()
        if regular is None:
            return self.scattered(points)
        xs, ys, grid = regular
        out = []
        for k, v in enumerate((xs, ys)):
            h = (v[-1] - v[0]) / (v.size - 1)
            p = points[:, k]
            f = np.clip((p - v[0]) / h, 0, v.size - 1)
            f[(p < v[0] - h / 2 - 1e-9) | (p > v[-1] + h / 2 + 1e-9)] = np.nan
            out.append(f)
        # bilinear gives NaN where an index is NaN (outside every comparison)
        return bilinear(grid, *out)

    def scattered(self, points: np.ndarray) -> np.ndarray:
        """The field at reference points (k, 2 or 3), linear between any cell centres.

        Linear on the Delaunay triangles of the centres in plan; outside them, the
        nearest centre's value where it lies within the centres' largest nearest-neighbour
        spacing (the half cells along the blank's edge); NaN beyond.

        Raises:
            InputError: Fewer than three centres, or all on a line.
        """
        from matplotlib.tri import LinearTriInterpolator, Triangulation

        c = self.X[:, :2]
        p = np.asarray(points, dtype=float)[:, :2]
        try:
            tri = Triangulation(c[:, 0], c[:, 1])
        except (ValueError, RuntimeError) as exc:
            raise InputError("final_shape.npz", f"the cell centres cannot be triangulated "
                             f"({exc})") from exc
        inside = LinearTriInterpolator(tri, self.values)(p[:, 0], p[:, 1])
        out = np.ma.filled(inside.astype(float), np.nan)
        # each centre's nearest neighbour is one of its Delaunay neighbours
        lengths = np.linalg.norm(c[tri.edges[:, 0]] - c[tri.edges[:, 1]], axis=1)
        nearest_neighbour = np.full(len(c), np.inf)
        for end in (0, 1):
            np.minimum.at(nearest_neighbour, tri.edges[:, end], lengths)
        reach = float(nearest_neighbour.max())
        missing = np.flatnonzero(np.isnan(out))
        if missing.size:
            dist = np.sum((p[missing, None, :] - c[None, :, :]) ** 2, axis=2)
            near = np.argmin(dist, axis=1)
            close = dist[np.arange(missing.size), near] <= reach ** 2 * (1 + 1e-9)
            out[missing[close]] = self.values[near[close]]
        return out


@dataclass(frozen=True)
class DrapeField:
    """A kinematic drape's node shear, addressed by the flat blank's material points.

    Attributes:
        node_shear: Shear at the net's nodes (rows, columns) [deg], NaN where not placed.
        centre: Where the origin cell's centre lies in the flat blank (x, y) [mm].
        spacing: Net spacing [mm].
        angle: Plan angle of the first family (rows) [deg].
        origin: Grid index of the origin node.
    """

    node_shear: np.ndarray
    centre: tuple[float, float]
    spacing: float
    angle: float
    origin: tuple[int, int]

    @classmethod
    def load(cls, folder: Path, centre: tuple[float, float] = (0.0, 0.0)) -> DrapeField:
        """From a ``forming drape`` folder (``drape.npz``).

        Args:
            folder: The drape's output folder.
            centre: The blank's point the net was centred on (``forming drape`` centres
                the origin cell on the tool's point closest to the blank's centre).
        """
        z = _load(Path(folder) / "drape.npz", ["node_shear", "spacing", "angle", "origin"])
        return cls(z["node_shear"], tuple(centre), float(z["spacing"]), float(z["angle"]),
                   tuple(int(v) for v in z["origin"]))

    @classmethod
    def from_drape_json(cls, folder: Path) -> DrapeField:
        """As :meth:`load`, centred on the middle of ``drape.json``'s blank box."""
        info = json.loads((Path(folder) / "drape.json").read_text())
        lo, hi = (np.asarray(c, dtype=float) for c in info["blank_box_mm"])
        return cls.load(folder, tuple(float(v) for v in ((lo + hi) / 2)[:2]))

    def at(self, points: np.ndarray) -> np.ndarray:
        """Node shear at reference points (k, 2 or 3), NaN off the placed net."""
        a = math.radians(self.angle)
        e1, e2 = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        rel = points[:, :2] - np.asarray(self.centre)
        fa = rel @ e1 / self.spacing + self.origin[0] + 0.5
        fb = rel @ e2 / self.spacing + self.origin[1] + 0.5
        return bilinear(self.node_shear, fa, fb)


def rms(difference: np.ndarray, weight: np.ndarray) -> tuple[float, float]:
    """Weighted RMS over the finite entries and the weight fraction they cover."""
    ok = np.isfinite(difference)
    if not ok.any():
        return float("nan"), 0.0
    w = weight[ok]
    return (float(np.sqrt(np.sum(w * difference[ok] ** 2) / np.sum(w))),
            float(np.sum(w) / np.sum(weight)))
