"""``forming drape CASE``: a kinematic drape onto a tool of a case, and its outputs.

The case's job is built as for a run (``--set`` applies); the net is draped onto one of
its tools at the end of the stroke (``tool.offset(1)``), centred on the tool's point
closest to the blank's centre (the centre of the origin cell). The tool's surface ends
where the blank cannot reach: outside the blank's bounding box swept by the tools'
travels (the hemisphere's punch ends at its equator, not down its shank); the net stops
there. Writes ``drape.json``, ``shear_angle.png``, ``drape.vtu`` (the net with its shear angles,
for ParaView), ``drape.npz`` (the net's arrays, :func:`write_npz`) and ``summary.json``
(the shape of a run's: status, assignments, metrics, timing, so that ``forming study
--drape`` tabulates drapes like runs) into the output folder, on rank 0.

The drape's own settings may also be given as ``--set drape.<name>=value`` (``spacing``,
``angle``, ``size``, ``tool``), which is how a study varies them.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from pathlib import Path

import numpy as np

from forming.drape import Drape, DrapeSettings, ShapeSurface, drape, project
from forming.errors import InputError

DRAPE_FILES = ("drape.json", "drape.json.tmp", "shear_angle.png", "drape.vtu", "drape.npz",
               "summary.json")
"""What ``forming drape`` writes; a rerun into the same folder removes these first."""

DRAPE_SETTINGS = ("spacing", "angle", "size", "tool")
"""The drape's settings that ``--set drape.<name>=value`` takes."""

DEFAULT_ANGLE = -45.0
"""Default plan-view angle of the first family [deg]: the skins' +/-45 deg NCF, stitch
along x (so that positive shear is the fabric model's positive branch)."""


def blank_box(scene) -> tuple[np.ndarray, np.ndarray, float]:
    """The whole blank's bounding box (lower, upper corners) [mm] and in-plane element size.

    A quarter or half model is mirrored on its symmetry planes: an axis is mirrored when
    the scene fixes that component on the ``xmin``/``ymin`` face (``<body>_xmin`` of a
    sandwich) lying at 0. The element
    size is the median spacing of the mesh's distinct x coordinates, at least 1/100 of the
    blank's larger in-plane side.
    """
    from forming.scene import Displacement

    x = scene.mesh.mesh.geometry.x
    lo, hi = x.min(axis=0), x.max(axis=0)
    for k, face in ((0, "xmin"), (1, "ymin")):
        # a sandwich's faces are named per body (``core_xmin``, ``skin_top_xmin``)
        fixed = any(isinstance(d, Displacement) and d.region in (face, f"{d.body}_{face}")
                    and d.components() == [(k, 0.0)] for d in scene.displacements)
        if scene.symmetry_copies > 1 and fixed and abs(lo[k]) <= 1e-9 * max(hi[k], 1.0):
            lo[k] = -hi[k]
    side = float(max(hi[:2] - lo[:2]))
    xs = np.unique(np.round(x[:, 0], 6))
    element = float(np.median(np.diff(xs))) if xs.size > 1 else side / 40
    return lo, hi, max(element, side / 100)


def wrinkling_limits(scene) -> tuple[float, float]:
    """The (positive, negative) wrinkling angles [deg].

    Those of the case's fabric, or else of the shipped NCF (+42 / -50).
    """
    from forming.materials.fabric import NonCrimpFabric

    for b in scene.bodies:
        if isinstance(b.material, NonCrimpFabric):
            return tuple(b.material.critical_angles_deg)
    return tuple(NonCrimpFabric().critical_angles_deg)


def case_drape(case: str, sets: list[str], tool: str | None = None,
               spacing: float | None = None, angle: float = DEFAULT_ANGLE,
               size: float | None = None, start: tuple[float, float, float] | None = None
               ) -> tuple[Drape, dict]:
    """Drape onto a tool of case ``case`` built with ``sets`` (``key=value``).

    Args:
        case: Case name (``forming list``).
        sets: The case's ``--set`` assignments.
        tool: The tool's name; None: the case's first tool.
        spacing: Net spacing [mm]; None: the blank's median in-plane element size (at
            least 1/100 of its side).
        angle: Plan-view angle of the first fibre family [deg].
        size: Side of the square net [mm]; None: the blank's larger side.
        start: Where the net's origin node is pinned [mm] (on the tool, at the end of the
            stroke); None: half a cell from the tool's point closest to the blank's centre,
            so that this point is the origin cell's centre (the net symmetric about it).

    Returns:
        The drape and a record of what was draped (case, tool, defaults used).

    Raises:
        InputError: Unknown case, parameter or tool (field ``--tool``), bad spacing,
            size, angle or start (fields ``--spacing``, ``--size``, ``--angle``,
            ``--start``).
    """
    from forming.case import prepare_case

    for name, value in (("--spacing", spacing), ("--size", size)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(name, f"must be a positive length [mm], got {value!r}")
    if not math.isfinite(angle):
        raise InputError("--angle", f"must be a finite angle [deg], got {angle!r}")
    job, _params = prepare_case(case, list(sets))
    scene = job.scene
    names = [t.name for t in scene.tools]
    if not names:
        raise InputError("--tool", f"case {case!r} has no tools to drape onto")
    if tool is None:
        tool = names[0]
    if tool not in names:
        raise InputError("--tool", f"unknown tool {tool!r}; tools of {case}: {names}")
    t = scene.tool(tool)
    lo, hi, element = blank_box(scene)
    # where the blank can be during the stroke: its box swept by every tool's travel
    travel = np.array([u.offset(1.0) - u.offset(0.0) for u in scene.tools])
    pad = 1e-6 * float(np.max(hi - lo))
    reach = (lo + np.minimum(travel.min(axis=0), 0.0) - pad,
             hi + np.maximum(travel.max(axis=0), 0.0) + pad)
    surface = ShapeSurface(t.shape, shift=tuple(float(v) for v in t.offset(1.0)),
                           bounds=tuple(tuple(float(v) for v in c) for c in reach))
    d = element if spacing is None else float(spacing)
    side = float(max(hi[:2] - lo[:2])) if size is None else float(size)
    n = max(2, math.ceil(side / d - 1e-9) + 1)
    centre = None
    if start is None:  # the closest point is the origin cell's centre: half a cell back
        centre = _closest_point(surface, (lo + hi) / 2, d, tool)
        a = math.radians(angle)
        back = np.array([math.cos(a) - math.sin(a), math.sin(a) + math.cos(a), 0.0])
        start = project(surface, centre - d / 2 * back)
    try:
        settings = DrapeSettings(start=tuple(float(v) for v in start), spacing=d,
                                 nodes=(n, n), angle=float(angle))
        result = drape(surface, settings)
    except InputError as exc:
        if exc.field == "start":
            raise InputError("--start", str(exc).split(": ", 1)[1]) from exc
        raise
    info = {"case": case, "sets": list(sets), "tool": tool,
            "tool_offset_mm": [float(v) for v in t.offset(1.0)],
            "blank_box_mm": [lo.tolist(), hi.tolist()],
            "tool_extent_mm": [c.tolist() for c in reach],
            "net_centre_mm": None if centre is None else centre.tolist(),
            "normal_at_start": surface.evaluate(result.nodes[settings.origin][None])[1][0]
            .tolist(),
            "net_side_mm": side, "wrinkling_limits_deg": list(wrinkling_limits(scene))}
    return result, info


def _closest_point(surface: ShapeSurface, point: np.ndarray, d: float, tool: str) -> np.ndarray:
    """The tool's point closest to ``point``.

    Retried slightly off ``point`` where the closest points form a whole circle (a die's
    opening seen from its axis, where the distance has no gradient).
    """
    for nudge in (0.0, 1e-3, 1e-2, 1e-1):
        p = project(surface, point + nudge * d * np.array([1.0, 0.7, 0.0]))
        if abs(surface.distance(p[None])[0]) < 1e-9 * max(1.0, float(np.abs(p).max())):
            return p
    raise InputError("--tool", f"found no point of {tool} near the blank's centre to start from")


def _prepare(out: Path) -> None:
    """An empty or new folder, or one holding an earlier drape (whose files go)."""
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} is a file, not a folder")
    if out.is_dir() and any(out.iterdir()):
        if not (out / "drape.json").is_file():
            raise InputError("--out", f"{out} is not empty and holds no earlier drape (no "
                             "drape.json): choose an empty or new folder")
        for name in DRAPE_FILES:
            (out / name).unlink(missing_ok=True)
    out.mkdir(parents=True, exist_ok=True)


def _shear_rms(result: Drape) -> float | None:
    """Area-weighted RMS of the placed cells' shear [deg]."""
    ok = np.isfinite(result.cell_shear) & np.isfinite(result.cell_area)
    a = result.cell_area[ok]
    return float(np.sqrt(np.sum(a * result.cell_shear[ok] ** 2) / a.sum())) if a.sum() else None


def summary(result: Drape, info: dict, wall: float, outputs: list[str]) -> dict:
    """What ``drape.json`` holds."""
    from forming.output import json_safe
    from forming.provenance import run_record

    lo, hi = result.shear_range()
    limits = tuple(info["wrinkling_limits_deg"])
    node = result.node_shear[np.isfinite(result.node_shear)]
    return json_safe(info | {
        "settings": dataclasses.asdict(result.settings),
        "shear_convention": "gamma = 90 - angle between the +row and +column fibres [deg], "
                            "positive when the families close; cell value: mean of its corners",
        "shear_min_deg": lo, "shear_max_deg": hi,
        "node_shear_min_deg": float(node.min()) if node.size else None,
        "node_shear_max_deg": float(node.max()) if node.size else None,
        "area_fraction_beyond_limits": result.area_fraction_beyond(limits),
        "draped_area_mm2": float(np.nansum(result.cell_area)),
        "shear_rms_deg": _shear_rms(result),
        "nodes_placed": result.placed, "nodes_total": int(np.prod(result.settings.nodes)),
        "not_placed": result.failures, "wall_s": wall, "outputs": outputs,
        "provenance": run_record()})


def write_vtu(result: Drape, path: Path, limits: tuple[float, float] = (42.0, -50.0)) -> Path:
    """The net as quadrilaterals with shear angles (``.vtu`` for ParaView)."""
    import meshio

    p = result.nodes.reshape(-1, 3)
    ok = np.isfinite(p[:, 0])
    index = np.full(len(p), -1)
    index[ok] = np.arange(ok.sum())
    rows, cols = result.settings.nodes
    ij = np.arange(rows * cols).reshape(rows, cols)
    quads = np.stack([ij[:-1, :-1], ij[1:, :-1], ij[1:, 1:], ij[:-1, 1:]], axis=-1)
    cell_ok = np.isfinite(result.cell_shear)
    shear = result.cell_shear[cell_ok]
    flat = result.flat_nodes().reshape(-1, 2)[ok]
    meshio.write(path, meshio.Mesh(
        p[ok], [("quad", index[quads[cell_ok]])],
        point_data={"node_shear_angle_deg": result.node_shear.reshape(-1)[ok],
                    "flat_position_mm": np.column_stack([flat, np.zeros(len(flat))])},
        cell_data={"shear_angle_deg": [shear], "area_mm2": [result.cell_area[cell_ok]],
                   "beyond_wrinkling_limit": [((shear > limits[0]) | (shear < limits[1]))
                                              .astype(np.int32)]}))
    return path


def write_npz(result: Drape, path: Path) -> Path:
    """The net's arrays (NaN where a node or cell was not placed), for scripts.

    ``nodes`` (rows, columns, 3) [mm], ``flat_nodes`` (rows, columns, 2) [mm] (the net
    before draping, through the start), ``node_shear`` (rows, columns) [deg],
    ``cell_shear`` and ``cell_area`` (rows - 1, columns - 1) [deg, mm^2], and the settings
    ``start``, ``spacing``, ``angle``, ``origin``.
    """
    st = result.settings
    np.savez_compressed(path, nodes=result.nodes, flat_nodes=result.flat_nodes(),
                        node_shear=result.node_shear, cell_shear=result.cell_shear,
                        cell_area=result.cell_area, start=np.asarray(st.start),
                        spacing=st.spacing, angle=st.angle, origin=np.asarray(st.origin))
    return path


def shear_picture(result: Drape, path: Path, title: str,
                  limits: tuple[float, float] = (42.0, -50.0), from_below: bool = False
                  ) -> Path:
    """Plan view of the draped net and the flat net, coloured by cell shear [deg].

    Args:
        result: The drape.
        path: The PNG to write.
        title: Its title.
        limits: Wrinkling angles (positive, negative) [deg], marked on the colour bar;
            cells beyond them are outlined black.
        from_below: The net lies under the tool (a punch pointing down): in the plan view
            lower cells are drawn over higher ones.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    p = result.nodes
    quads = np.stack([p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]], axis=2)
    f = result.flat_nodes()
    flat = np.stack([f[:-1, :-1], f[1:, :-1], f[1:, 1:], f[:-1, 1:]], axis=2)
    ok = np.isfinite(result.cell_shear)
    shear = result.cell_shear[ok]
    bound = max(55.0, float(np.abs(shear).max()) if shear.size else 0.0)
    norm = Normalize(-bound, bound)
    fig = Figure(figsize=(13, 6.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    beyond = (shear > limits[0]) | (shear < limits[1])
    z = quads[ok][:, :, 2].mean(axis=1)
    order = np.argsort(-z if from_below else z)  # the cells nearer the viewer drawn last
    front = "lower" if from_below else "upper"
    for ax, polys, keys, sub in (
            (axes[0], quads[ok][:, :, :2], order, f"draped, plan view (x-y), {front} cells in "
                                                  "front"),
            (axes[1], flat[ok], np.arange(len(shear)), "flat net (the fabric before draping)")):
        pc = PolyCollection(polys[keys], array=shear[keys], cmap="coolwarm", norm=norm,
                            edgecolors=list(np.where(beyond[keys], "black", "0.35")),
                            linewidths=np.where(beyond[keys], 1.2, 0.15))
        ax.add_collection(pc)
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_title(sub, fontsize=10)
    bar = fig.colorbar(pc, ax=axes, shrink=0.85, label="shear angle [deg] (positive: fibres "
                       "close); black lines: wrinkling limits")
    for lim in limits:
        bar.ax.axhline(lim, color="black", linewidth=2.5)
        bar.ax.text(-0.15, lim, f"{lim:+g}", transform=bar.ax.get_yaxis_transform(),
                    ha="right", va="center", fontsize=9, fontweight="bold")
    lo, hi = result.shear_range()
    fig.suptitle(f"{title}\nshear {lo:.1f} to {hi:.1f} deg; cells beyond {limits[0]:+g} / "
                 f"{limits[1]:+g} deg outlined black "
                 f"({result.area_fraction_beyond(limits):.1%} of the area)", fontsize=11)
    fig.savefig(path, dpi=110)
    return path


def drape_settings(sets: list[str], given: dict[str, object]) -> tuple[list[str], dict]:
    """The case's assignments, and the drape's settings with ``drape.*`` ones merged in.

    Args:
        sets: ``key=value`` assignments; ``drape.<name>=value`` ones are the drape's.
        given: The drape's settings from their own options (None: not given).

    Raises:
        InputError: An unknown ``drape.`` setting, a value that is not a number, or a
            setting given both ways.
    """
    case_sets, merged = [], dict(given)
    for a in sets:
        key, _sep, value = a.partition("=")
        key = key.strip()
        if not key.startswith("drape."):
            case_sets.append(a)
            continue
        name = key.removeprefix("drape.")
        if name not in DRAPE_SETTINGS:
            raise InputError(f"--set {key}", f"the drape has no setting {name!r}; it has "
                             f"{', '.join(DRAPE_SETTINGS)}")
        if merged.get(name) is not None:
            raise InputError(f"--set {key}", f"given twice (also as --{name})")
        if name == "tool":
            merged[name] = value.strip()
            continue
        try:
            merged[name] = float(value)
        except ValueError:
            raise InputError(f"--set {key}", f"expected a number, got {value!r}") from None
    return case_sets, merged


def _run_summary(record: dict, sets: list[str]) -> dict:
    """``summary.json``: the drape in the shape of a run's summary (for studies)."""
    placed = int(record["nodes_placed"])
    metrics = {k: record[k] for k in ("shear_min_deg", "shear_max_deg", "node_shear_min_deg",
                                      "node_shear_max_deg", "area_fraction_beyond_limits",
                                      "draped_area_mm2", "shear_rms_deg")}
    return {"case": record["case"], "status": "completed", "reason": None,
            "solver": "kinematic drape", "assignments": list(sets),
            "metrics": metrics | {"nodes_placed": placed},
            "timing": {"wall_s": record["wall_s"], "steps": 0, "work": 0},
            "mesh": {"dofs": 3 * placed, "net_nodes": placed},
            "run": record["provenance"], "outputs": record["outputs"]}


def run_drape(case: str, sets: list[str], out: Path, tool: str | None = None,
              spacing: float | None = None, angle: float | None = None,
              size: float | None = None, start: tuple[float, float, float] | None = None,
              comm=None) -> dict:
    """Drape onto a case's tool and write the outputs into ``out`` (rank 0).

    ``sets`` may hold the drape's own settings as ``drape.<name>=value``.

    Returns:
        The contents of ``drape.json``.
    """
    assignments = list(sets)  # as given, drape settings included (the summary's)
    sets, opts = drape_settings(assignments, {"tool": tool, "spacing": spacing,
                                              "angle": angle, "size": size})
    tool, spacing, size = opts["tool"], opts["spacing"], opts["size"]
    angle = DEFAULT_ANGLE if opts["angle"] is None else opts["angle"]
    t0 = time.perf_counter()
    problem = None
    if comm is None or comm.rank == 0:
        try:
            _prepare(Path(out))
        except InputError as exc:
            problem = (exc.field, str(exc).split(": ", 1)[1])
        except OSError as exc:
            problem = ("--out", f"{out}: {exc.strerror or exc}")
    if comm is not None:
        problem = comm.bcast(problem, root=0)
    if problem is not None:
        raise InputError(*problem)
    result, info = case_drape(case, sets, tool, spacing, angle, size, start)
    out = Path(out)
    if comm is not None and comm.rank != 0:
        return {}
    st = result.settings
    limits = tuple(info["wrinkling_limits_deg"])
    title = (f"{case}: kinematic drape onto the {info['tool']}, d = {st.spacing:.3g} mm, "
             f"{st.nodes[0]} x {st.nodes[1]} nodes, fibres at {st.angle:g} / "
             f"{st.angle + 90:g} deg")
    below = info["normal_at_start"][2] < 0
    outputs = [shear_picture(result, out / "shear_angle.png", title, limits, below).name,
               write_vtu(result, out / "drape.vtu", limits).name,
               write_npz(result, out / "drape.npz").name]
    record = summary(result, info, time.perf_counter() - t0,
                     ["drape.json", *outputs, "summary.json"])
    tmp = out / "drape.json.tmp"
    tmp.write_text(json.dumps(record, indent=2))
    tmp.replace(out / "drape.json")
    tmp.write_text(json.dumps(_run_summary(record, assignments), indent=2))
    tmp.replace(out / "summary.json")
    return record
