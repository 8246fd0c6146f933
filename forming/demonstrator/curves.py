"""Blank outlines and trim lines of a component: read, checked, cut to the modelled quarter.

Both are closed curves in plan given as CSV files of x, y points (a header line is
allowed; a last point equal to the first is dropped) or as DXF files holding one closed
outline (:mod:`forming.demonstrator.dxf`). The demonstrator models a quarter
of a part symmetric about x = 0 and y = 0, so a blank outline must be symmetric too:
:func:`quarter` cuts it to x >= 0, y >= 0 and refuses one that is not.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forming.errors import InputError
from forming.outline import Outline


def read_points(path: Path | str, field: str) -> np.ndarray:
    """The (n, 2) points of a CSV file of x, y rows or of a DXF file's one closed outline.

    Raises:
        InputError: naming ``field`` and the file, for anything unreadable.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(field, f"{path}: no such file")
    if path.suffix.lower() == ".dxf":
        from forming.demonstrator.dxf import read_outline

        return read_outline(path, field)
    rows = []
    for k, line in enumerate(path.read_text().splitlines(), start=1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        cells = [c.strip() for c in text.replace(";", ",").split(",") if c.strip()]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not rows:  # a header
                continue
            raise InputError(field, f"{path}, line {k}: not two numbers: {text!r}") from None
        if len(values) != 2 or not np.all(np.isfinite(values)):
            raise InputError(field, f"{path}, line {k}: expected finite x, y, got {text!r}")
        rows.append(values)
    if len(rows) < 3:
        raise InputError(field, f"{path}: a closed curve needs at least 3 points, got "
                         f"{len(rows)}")
    return np.asarray(rows, dtype=float)


def closed_curve(points: np.ndarray, field: str, source: str = "") -> np.ndarray:
    """The points of a closed, simple curve (counter-clockwise), checked.

    A curve whose closing segment is more than five times its longest other segment is
    taken as open (the last point was meant to meet the first).
    """
    pts = np.asarray(points, dtype=float)
    where = f"{source}: " if source else ""
    if len(pts) > 3 and np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    else:
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        closing = float(np.linalg.norm(pts[-1] - pts[0]))
        if len(seg) and closing > 5.0 * float(seg.max()):
            raise InputError(field, f"{where}the curve is open: its last point "
                             f"{pts[-1].round(3).tolist()} is {closing:.4g} mm from its first "
                             f"(the longest other segment is {seg.max():.4g} mm)")
    try:
        outline = Outline(tuple(map(tuple, pts)))
    except InputError as exc:
        raise InputError(field, f"{where}{str(exc).removeprefix(exc.field + ': ')}") from None
    return np.asarray(outline.points)


def _clip(pts: np.ndarray, axis: int) -> np.ndarray:
    """Sutherland-Hodgman: the part of the closed polygon with coordinate ``axis`` >= 0."""
    out = []
    for a, b in zip(pts, np.roll(pts, -1, axis=0), strict=True):
        ina, inb = a[axis] >= 0.0, b[axis] >= 0.0
        if ina:
            out.append(a)
        if ina != inb:
            t = a[axis] / (a[axis] - b[axis])
            p = a + t * (b - a)
            p[axis] = 0.0
            out.append(p)
    return np.asarray(out)


def distance_to_polyline(q: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance of points q (m, 2) to the edges of the closed polyline pts (n, 2)."""
    a, b = pts, np.roll(pts, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("mnk,nk->mn", q[:, None] - a[None], ab)
                / np.maximum(np.einsum("nk,nk->n", ab, ab), 1e-300), 0.0, 1.0)
    c = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(q[:, None] - c, axis=2).min(axis=1)


def quarter(points: np.ndarray, field: str = "--set blank") -> Outline:
    """The quarter x >= 0, y >= 0 of a closed outline symmetric about both axes.

    Raises:
        InputError: The outline is not symmetric about x = 0 and y = 0 (within 0.1% of
            its size), or does not enclose the origin.
    """
    pts = closed_curve(points, field)
    size = float(np.ptp(pts, axis=0).max())
    for flip, name in (((-1, 1), "x = 0"), ((1, -1), "y = 0")):
        off = distance_to_polyline(pts * np.asarray(flip), pts).max()
        if off > 1e-3 * size:
            raise InputError(field, f"the outline is not symmetric about {name} (a mirrored "
                             f"point is {off:.4g} mm off it); the case models a quarter")
    q = _clip(_clip(pts, 0), 1)
    if len(q) < 3 or not np.any(np.all(np.abs(q) < 1e-9 * size, axis=1)):
        raise InputError(field, "the outline must enclose the origin (the part's centre)")
    keep = np.ones(len(q), dtype=bool)  # drop points repeated by the clipping
    keep[1:] = np.linalg.norm(np.diff(q, axis=0), axis=1) > 1e-9 * size
    return Outline(tuple(map(tuple, q[keep])))
