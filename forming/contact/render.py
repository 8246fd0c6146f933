"""Pictures and ParaView files of the rigid tools, and sections and 3D views of a body.

Tools are signed-distance functions (``shape.distance(p, NUMPY)``, positive outside),
so their surfaces are drawn as zero level sets: a triangulated iso-surface in 3D
(:func:`tool_surface`) or a zero contour in a section plane (:func:`section_plot`).
Nothing here uses MPI; call it on one rank.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyvista
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from vtkmodules.vtkCommonCore import vtkLogger

from forming.contact.shapes import NUMPY, Shape

Bounds = tuple[float, float, float, float, float, float]

# Cap on the points of the sampling grid of tool_surface (the spacing is coarsened).
_MAX_POINTS = 2_000_000
# Points along the longer side of a section's sampling grid.
_SECTION_SAMPLES = 600
# Padding of a section's extent, as a fraction of its larger span.
_PAD = 0.15
_TOOL_FILL = "0.85"
_TOOL_LINES = ("0.1", "darkred", "navy", "darkgreen", "purple", "saddlebrown")
# A vertical scalar bar at the right of a 3D picture.
_SCALAR_BAR = {"color": "black", "vertical": True, "position_x": 0.86, "position_y": 0.15,
               "width": 0.06, "height": 0.7, "title_font_size": 18, "label_font_size": 16}


def _grid_counts(span: np.ndarray, resolution: float) -> np.ndarray:
    """Points per axis for a spacing of about ``resolution``, at most ``_MAX_POINTS`` in all."""
    h = resolution
    while True:
        counts = np.maximum(np.ceil(span / h).astype(int) + 1, 2)
        total = int(np.prod(counts))
        if total <= _MAX_POINTS:
            return counts
        h *= 1.01 * (total / _MAX_POINTS) ** (1.0 / 3.0)


def _image_grid(bounds: Bounds, resolution: float) -> pyvista.ImageData:
    """A uniform grid spanning ``bounds`` with a spacing of about ``resolution``.

    Raises:
        ValueError: If the bounds are empty or not finite, or the resolution not positive.
    """
    lo = np.asarray(bounds[0::2], dtype=float)
    hi = np.asarray(bounds[1::2], dtype=float)
    if lo.size != 3 or hi.size != 3 or not np.all(np.isfinite(lo) & np.isfinite(hi)):
        raise ValueError(f"bounds must be 6 finite numbers, got {bounds!r}")
    if not np.all(hi > lo):
        raise ValueError(f"bounds are empty: {bounds!r}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive number, got {resolution!r}")
    counts = _grid_counts(hi - lo, resolution)
    return pyvista.ImageData(dimensions=tuple(int(c) for c in counts),
                             spacing=tuple((hi - lo) / (counts - 1)), origin=tuple(lo))


def _distance(shape: Shape, p: np.ndarray) -> np.ndarray:
    """Signed distance of the (3, n) points ``p``, always as an array of n values."""
    return np.broadcast_to(np.asarray(shape.distance(p, NUMPY), dtype=float), p.shape[1:])


def tool_surface(shape: Shape, bounds: Bounds, resolution: float) -> pyvista.PolyData:
    """The surface of a tool (in its initial position) inside a box.

    Args:
        shape: A tool shape with a signed ``distance(p, xp)``.
        bounds: The box, (xmin, xmax, ymin, ymax, zmin, zmax) [mm].
        resolution: Spacing of the sampling grid [mm]; coarsened to keep the grid at
            about two million points at most.

    Returns:
        The triangulated zero level set of the distance (a surface-mesh tool: its own
        triangles), empty when the tool does not cross the box.

    Raises:
        ValueError: If the bounds are empty or the resolution is not positive.
    """
    grid = _image_grid(bounds, resolution)
    if shape.tracked:
        surface = shape.polydata().clip_box(list(bounds), invert=False).extract_surface(
            algorithm="dataset_surface")
        surface.clear_data()
        return surface
    d = _distance(shape, np.asarray(grid.points, dtype=float).T)
    if d.min() > 0.0 or d.max() < 0.0:
        return pyvista.PolyData()
    grid.point_data["distance"] = d
    surface = grid.contour([0.0], scalars="distance")
    surface.clear_data()
    return surface


def _translated(surface: pyvista.PolyData, offset: np.ndarray) -> pyvista.PolyData:
    """A copy of ``surface`` moved by ``offset``."""
    moved = surface.copy()
    if moved.n_points:
        moved.points = np.asarray(surface.points) + np.asarray(offset, dtype=float).reshape(3)
    return moved


class ToolSeries:
    """Time series of tool surfaces written as VTK PolyData plus a ParaView collection.

    Each tool's surface is built once; every :meth:`write` saves it translated by the
    tool's current offset as ``out/tools/<name>_<step>.vtp`` and rewrites
    ``out/tool_<name>.pvd`` listing every step written so far. A tool that has not moved
    since its last file is not written again: the collection points that step at the
    earlier file (a die or blank holder at rest is one file). Files are compressed with
    LZ4 (2.6 times faster to write than zlib on a 90,000-point surface, files twice as
    large).

    Args:
        out: Output directory.
        tools: (name, shape) of each tool.
        bounds: Box in which the surfaces are built, (xmin, xmax, ymin, ymax, zmin, zmax).
        resolution: Spacing of the sampling grid [mm].
    """

    def __init__(self, out: Path, tools: list[tuple[str, Shape]], bounds: Bounds,
                 resolution: float) -> None:
        self.out = Path(out)
        self.surfaces = {name: tool_surface(shape, bounds, resolution) for name, shape in tools}
        # per tool: step -> (time, step whose file holds the surface)
        self._steps: dict[str, dict[int, tuple[float, int]]] = {n: {} for n in self.surfaces}
        self._last: dict[str, tuple[tuple[float, ...], int]] = {}

    def write(self, step: int, t: float, offsets: dict[str, np.ndarray]) -> None:
        """Write every tool at one step.

        Args:
            step: Step number (names the files).
            t: Time of the step.
            offsets: Displacement of each tool from its initial position (length 3).
        """
        (self.out / "tools").mkdir(parents=True, exist_ok=True)
        for name, surface in self.surfaces.items():
            offset = tuple(float(v) for v in np.asarray(offsets[name]).ravel())
            last = self._last.get(name)
            if last is None or last[0] != offset or \
                    not (self.out / self._file(name, last[1])).is_file():
                _translated(surface, offsets[name]).save(self.out / self._file(name, step),
                                                         compression="lz4")
                self._last[name] = last = (offset, step)
            self._steps[name][step] = (float(t), last[1])
            self._write_collection(name)

    @staticmethod
    def _file(name: str, step: int) -> str:
        return f"tools/{name}_{step:05d}.vtp"

    def _write_collection(self, name: str) -> None:
        entries = "".join(
            f'    <DataSet timestep="{t}" part="0" file="{self._file(name, held)}"/>\n'
            for _step, (t, held) in sorted(self._steps[name].items()))
        text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                f"  <Collection>\n{entries}  </Collection>\n</VTKFile>\n")
        (self.out / f"tool_{name}.pvd").write_text(text)


def _section_polygons(polygons: list[np.ndarray], values: np.ndarray,
                      mirror: bool) -> tuple[list[np.ndarray], np.ndarray]:
    """The polygons (and their values) to draw, with their mirror images if asked."""
    polys = [np.asarray(poly, dtype=float).reshape(-1, 2) for poly in polygons]
    vals = np.asarray(values, dtype=float).ravel()
    if not polys:
        raise ValueError("no polygons to draw")
    if vals.size != len(polys):
        raise ValueError(f"{len(polys)} polygons but {vals.size} values")
    if mirror:
        polys += [poly * np.array([-1.0, 1.0]) for poly in polys]
        vals = np.concatenate([vals, vals])
    return polys, vals


def _padded_extent(polygons: list[np.ndarray]) -> tuple[float, float, float, float]:
    """(umin, umax, vmin, vmax) of the polygons padded by ``_PAD`` of the larger span."""
    points = np.concatenate(polygons)
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = _PAD * max(float(np.max(hi - lo)), 1e-9)
    return lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad


def _section_distance(shape: Shape, offset: np.ndarray, plane: tuple[int, float],
                      axes: tuple[int, int], extent: tuple[float, float, float, float],
                      mirror: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid coordinates (u, v) over ``extent`` and the tool's distance at them."""
    h = max(extent[1] - extent[0], extent[3] - extent[2]) / _SECTION_SAMPLES
    u = np.linspace(extent[0], extent[1], int(np.ceil((extent[1] - extent[0]) / h)) + 1)
    v = np.linspace(extent[2], extent[3], int(np.ceil((extent[3] - extent[2]) / h)) + 1)
    uu, vv = np.meshgrid(u, v)
    p = np.empty((3, uu.size))
    p[plane[0]] = plane[1]
    p[axes[0]] = np.abs(uu.ravel()) if mirror else uu.ravel()
    p[axes[1]] = vv.ravel()
    p -= np.asarray(offset, dtype=float).reshape(3, 1)
    return uu, vv, _distance(shape, p).reshape(uu.shape)


def _draw_tool(ax, uu: np.ndarray, vv: np.ndarray, d: np.ndarray, name: str,
               colour: str) -> Patch:
    """Fill the inside of a tool in grey, outline it, and return its legend entry."""
    if d.min() < 0.0:
        ax.contourf(uu, vv, d, levels=[d.min() - 1.0, 0.0], colors=[_TOOL_FILL], zorder=1)
        if d.max() > 0.0:
            ax.contour(uu, vv, d, levels=[0.0], colors=[colour], linewidths=1.2, zorder=3)
    return Patch(facecolor=_TOOL_FILL, edgecolor=colour, label=name)


def _section_figure(extent: tuple[float, float, float, float]) -> Figure:
    """A figure sized to the aspect ratio of ``extent`` (plus room for the colour bar)."""
    ratio = (extent[3] - extent[2]) / (extent[1] - extent[0])
    width = 9.0
    height = min(max(0.75 * width * ratio + 1.0, 2.5), 10.0)
    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    return fig


def section_plot(path: Path, polygons: list[np.ndarray], values: np.ndarray,
                 tools: list[tuple[str, Shape, np.ndarray]], plane: tuple[int, float],
                 axes: tuple[int, int], *, label: str, title: str, mirror: bool = False,
                 vmin: float | None = None, vmax: float | None = None,
                 extra: list[np.ndarray] = ()) -> Path:
    """Save a PNG of a section through the body, coloured by a cell value, with the tools.

    Args:
        path: PNG file to write.
        polygons: In-plane (deformed) coordinates of each cell's cut face, (k, 2) each.
        values: One value per polygon.
        tools: (name, shape, offset) of each tool; the tool is drawn where
            ``shape.distance(p - offset) < 0`` in the section plane.
        plane: (axis index, coordinate) of the section plane, e.g. (1, 0.0) for y = 0.
        axes: The in-plane axes drawn horizontally and vertically, e.g. (0, 2).
        label: Colour bar label.
        title: Plot title.
        mirror: Also draw the polygons and tools mirrored about the horizontal axis'
            zero (a quarter model shown as a half section).
        vmin: Lower colour limit (default: the smallest value).
        vmax: Upper colour limit (default: the largest value).
        extra: Further polygons drawn dark, uncoloured (thin layers such as skins).

    Returns:
        ``path``.

    Raises:
        ValueError: If there are no polygons, their number differs from the values', or
            ``plane`` and ``axes`` do not name three different axes.
    """
    if sorted((plane[0], *axes)) != [0, 1, 2]:
        raise ValueError(f"plane axis {plane[0]} and axes {axes} must be 0, 1, 2 in some order")
    polys, vals = _section_polygons(polygons, values, mirror)
    extent = _padded_extent(polys)
    fig = _section_figure(extent)
    ax = fig.add_subplot()
    cells = PolyCollection(polys, array=vals, cmap="viridis", edgecolors="0.2",
                           linewidths=0.3, zorder=2)
    cells.set_clim(vmin, vmax)
    ax.add_collection(cells)
    if len(extra):
        layers, _v = _section_polygons(list(extra), np.zeros(len(extra)), mirror)
        ax.add_collection(PolyCollection(layers, facecolors="0.15", edgecolors="0.15",
                                         linewidths=0.3, zorder=2.5))
    fig.colorbar(cells, cax=ax.inset_axes((1.03, 0.0, 0.03, 1.0)), label=label)
    handles = [_draw_tool(ax, *_section_distance(shape, offset, plane, axes, extent, mirror),
                          name, _TOOL_LINES[i % len(_TOOL_LINES)])
               for i, (name, shape, offset) in enumerate(tools)]
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize="small")
    ax.set(xlim=extent[:2], ylim=extent[2:], title=title, aspect="equal",
           xlabel=f"{'xyz'[axes[0]]} [mm]", ylabel=f"{'xyz'[axes[1]]} [mm]")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    return path


def render_3d(path: Path, grid: pyvista.UnstructuredGrid, scalars: str,
              tools: list[tuple[Shape, np.ndarray]], bounds: Bounds, resolution: float, *,
              title: str, clim: tuple[float, float] | None = None,
              view: str = "isometric", cmap: str = "viridis") -> Path:
    """Save an off-screen isometric picture of a body coloured by an array, with the tools.

    Args:
        path: PNG file to write.
        grid: The body, in its deformed configuration.
        scalars: Name of a cell or point array of ``grid`` to colour by.
        tools: (shape, offset) of each tool, drawn semi-transparent.
        bounds: Box in which the tool surfaces are built (initial positions).
        resolution: Spacing of the tools' sampling grid [mm].
        title: Title written on the picture.
        clim: Colour limits (default: the array's range).
        view: ``"isometric"`` or ``"xy"`` (from above, for a blank's in-plane fields).
        cmap: Matplotlib colour map name.

    Returns:
        ``path``.
    """
    pyvista.OFF_SCREEN = True
    # VTK warns on stderr that it has no X display, though off-screen rendering works
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 900))
    try:
        plotter.set_background("white")
        plotter.add_mesh(grid, scalars=scalars, cmap=cmap, clim=clim,
                         scalar_bar_args=_SCALAR_BAR | {"title": scalars})
        for shape, offset in tools:
            surface = _translated(tool_surface(shape, bounds, resolution), offset)
            if surface.n_points:
                plotter.add_mesh(surface, color="grey", opacity=0.35)
        plotter.add_title(title, font_size=12, color="black")
        # orientation triad and the body's extent in mm: a reader can tell x from y
        plotter.add_axes(color="black", xlabel="x", ylabel="y", zlabel="z")
        plotter.show_bounds(mesh=grid, xtitle="x [mm]", ytitle="y [mm]", ztitle="z [mm]",
                            color="black", font_size=10, location="outer", ticks="outside")
        if view == "xy":
            plotter.view_xy()
        else:
            plotter.view_isometric()
        plotter.screenshot(str(path))
    finally:
        plotter.close()
    return path
