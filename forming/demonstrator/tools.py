"""The demonstrator's matched tools as OpenCASCADE solids, written as STEP and STL.

Each working face is a height field over the tool's plan; it becomes the bicubic
B-spline surface that interpolates it on a plan grid (control points solved here, so the
surface passes through the grid points), and the tool is that face extruded away from
the cavity: the lower tool below its face, the upper one above. The solids are written
in their closed positions (the cavity between them is the finished part) as
``lower.step``/``.stl`` and ``upper.step``/``.stl``, with the trim line as ``trim.csv``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forming.cad import Tessellation, gmsh_session, write_tool
from forming.demonstrator.geometry import Component
from forming.errors import InputError

GRID = 5.0  # largest spacing of the lofted sections and of the points along them [mm]


DEGREE = 3  # the working faces are bicubic B-spline surfaces


def _knots(n: int) -> np.ndarray:
    """Clamped knots of a cubic B-spline interpolating n points at u = linspace(0, 1, n).

    Interior knots by de Boor's averaging of the parameters, so the collocation matrix
    is non-singular (Schoenberg-Whitney).
    """
    u = np.linspace(0.0, 1.0, n)
    inner = [u[j:j + DEGREE].mean() for j in range(1, n - DEGREE)]
    return np.concatenate([np.zeros(DEGREE + 1), inner, np.ones(DEGREE + 1)])


def _basis(knots: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Values (len(u), n) of the n B-spline basis functions of degree 3 (Cox-de Boor)."""
    n = len(knots) - DEGREE - 1
    last = np.searchsorted(knots, 1.0, side="left") - 1  # u = 1 lies in the last span
    b = np.zeros((len(u), len(knots) - 1))
    span = np.clip(np.searchsorted(knots, u, side="right") - 1, 0, last)
    b[np.arange(len(u)), span] = 1.0
    for p in range(1, DEGREE + 1):
        nxt = np.zeros((len(u), len(knots) - 1 - p))
        for i in range(len(knots) - 1 - p):
            d1, d2 = knots[i + p] - knots[i], knots[i + p + 1] - knots[i + 1]
            if d1 > 0:
                nxt[:, i] += (u - knots[i]) / d1 * b[:, i]
            if d2 > 0:
                nxt[:, i] += (knots[i + p + 1] - u) / d2 * b[:, i + 1]
        b = nxt
    return b[:, :n]


def interpolating_surface(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Control points and knots of the bicubic B-spline through an (ny, nx, 3) grid.

    Returns:
        Control points (ny, nx, 3) and the clamped knot vectors along x (u) and y (v).
    """
    ny, nx, _ = points.shape
    ku, kv = _knots(nx), _knots(ny)
    au = _basis(ku, np.linspace(0.0, 1.0, nx))
    av = _basis(kv, np.linspace(0.0, 1.0, ny))
    ctrl = np.linalg.solve(av, np.linalg.solve(au, points.transpose(1, 0, 2).reshape(nx, -1))
                           .reshape(nx, ny, 3).transpose(1, 0, 2).reshape(ny, -1))
    return ctrl.reshape(ny, nx, 3), ku, kv


def _solid(gmsh, component: Component, upper: bool, grid: float) -> None:
    """The lower or upper tool as one solid in the current gmsh model.

    The working face is the bicubic B-spline interpolating the face's height on a plan
    grid of spacing at most ``grid``; the solid is that face extruded by ``tool_height``
    away from the cavity (-z for the lower tool, +z for the upper one).
    """
    occ = gmsh.model.occ
    hx, hy = component.tool_extent()
    nx, ny = (int(np.ceil(2 * h / grid)) + 1 for h in (hx, hy))
    x, y = np.meshgrid(np.linspace(-hx, hx, nx), np.linspace(-hy, hy, ny))
    z = component.upper_z(x, y) if upper else component.lower_z(x, y)
    ctrl, ku, kv = interpolating_surface(np.stack([x, y, z], axis=-1))
    tags = [occ.addPoint(*map(float, p)) for p in ctrl.reshape(-1, 3)]
    mult = lambda k: [DEGREE + 1] + [1] * (len(np.unique(k)) - 2) + [DEGREE + 1]  # noqa: E731
    face = occ.addBSplineSurface(tags, nx, degreeU=DEGREE, degreeV=DEGREE,
                                 knotsU=list(np.unique(ku)), knotsV=list(np.unique(kv)),
                                 multiplicitiesU=mult(ku), multiplicitiesV=mult(kv))
    h = component.tool_height
    occ.extrude([(2, face)], 0.0, 0.0, h if upper else -h)
    occ.remove([(0, t) for t in tags])
    occ.synchronize()
    if len(gmsh.model.getEntities(3)) != 1:
        raise InputError("component", "the tool's working face did not extrude to one solid")


def write_trim(path: Path, component: Component) -> Path:
    """The trim line as a CSV of x, y points (closed polygon, first point not repeated)."""
    pts = component.trim_points()
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, pts, delimiter=",", header="x_mm,y_mm", comments="", fmt="%.6f")
    return path


def tool_files(directory: Path, component: Component, tess: Tessellation | None = None,
               grid: float = GRID) -> dict[str, Path]:
    """Write ``lower`` and ``upper`` (.step and .stl) and ``trim.csv`` into ``directory``.

    Returns:
        The STL of each tool and the trim CSV (keys ``lower``, ``upper``, ``trim``).
    """
    tess = tess or Tessellation(angle=4.0, max_size=12.0)
    out = {}
    with gmsh_session() as gmsh:
        for name in ("lower", "upper"):
            gmsh.model.add(f"demonstrator_{name}")
            try:
                _solid(gmsh, component, name == "upper", grid)
                out[name] = write_tool(gmsh, Path(directory) / name, tess)[1]
            finally:
                gmsh.model.remove()
    out["trim"] = write_trim(Path(directory) / "trim.csv", component)
    return out
