"""The demonstrator's PNGs: plan maps of the whole part and a section through y = 0.

Each map draws the quarter's faces mirrored into the whole part, in plan, with the trim
line dashed. Called on rank 0 with the analysis of :class:`~forming.demonstrator.report
.Report` (``section_data`` is collective).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from forming.demonstrator.geometry import COPIES
from forming.demonstrator.setup import Part


def _figure(panels: int) -> tuple[Figure, list]:
    fig = Figure(figsize=(6.5 * panels, 5.2))
    FigureCanvasAgg(fig)
    return fig, [fig.add_subplot(1, panels, k + 1) for k in range(panels)]


def _plan(ax, polygons: np.ndarray, values: np.ndarray, part: Part, *, title: str,
          label: str, cmap: str = "viridis", clim=None, marked: np.ndarray | None = None,
          reference: bool = False) -> None:
    """Faces (n, 4, 3) in plan, mirrored into the whole part, coloured by ``values``."""
    xy = polygons[:, :, :2]
    polys = np.concatenate([xy * np.asarray(c) for c in COPIES])
    vals = np.tile(values, len(COPIES))
    coll = PolyCollection(polys, array=vals, cmap=cmap, edgecolors="face", linewidths=0.2)
    if clim is not None:
        coll.set_clim(*clim)
    ax.add_collection(coll)
    if marked is not None and marked.any():
        edge = PolyCollection(np.concatenate([xy[marked] * np.asarray(c) for c in COPIES]),
                              facecolors="none", edgecolors="black", linewidths=1.0)
        ax.add_collection(edge)
    trim = np.vstack([part.trim, part.trim[:1]])
    ax.plot(trim[:, 0], trim[:, 1], "k--", lw=0.8, label="trim line")
    blank = np.vstack([part.blank, part.blank[:1]])
    ax.plot(blank[:, 0], blank[:, 1], color="0.6", lw=0.6,
            label="flat blank" if reference else None)
    lim = 1.05 * np.abs(np.vstack([polys.reshape(-1, 2), part.blank])).max(axis=0)
    ax.set(xlim=(-lim[0], lim[0]), ylim=(-lim[1], lim[1]), aspect="equal", title=title,
           xlabel="x [mm]", ylabel="y [mm]")
    ax.figure.colorbar(coll, ax=ax, label=label, shrink=0.85)
    ax.legend(loc="lower right", fontsize="x-small")


def _skins(out: Path, name: str, a: dict, part: Part, what, **style) -> Path:
    """Both skins' tool-side faces side by side; ``what(faces) -> (values, marked, title)``."""
    fig, axes = _figure(2)
    for ax, skin in zip(axes, ("skin_top", "skin_bottom"), strict=True):
        faces = a["fields"][skin][0]
        values, marked, title = what(faces)
        _plan(ax, faces.polygons, values, part, marked=marked,
              title=f"{skin.replace('_', ' ')}: {title}", **style)
    return _save(fig, out / name)


def shear_map(out: Path, a: dict, limits: tuple[float, float], part: Part) -> Path:
    """Both skins' shear angles, the cells beyond the wrinkling angles outlined."""
    hi, lo = limits
    # the colours span the shear found (the limits would wash out a mild part's map)
    bound = max(5.0, *(float(np.abs(a["fields"][s][0].value("shear")).max(initial=0.0))
                       for s in ("skin_top", "skin_bottom")))

    def what(faces):
        gamma = faces.value("shear")
        return gamma, (gamma > hi) | (gamma < lo), \
            f"shear angle, {gamma.min():+.1f} to {gamma.max():+.1f} deg\n(outlined: " \
            f"beyond the wrinkling limits {hi:+g} / {lo:+g} deg)"

    return _skins(out, "shear_angle_map.png", a, part, what, cmap="coolwarm",
                  clim=(-bound, bound), label="shear angle [deg]")


def fibre_map(out: Path, a: dict, threshold: float, part: Part) -> Path:
    """Both skins' shorter-tow strain; compressed cells outlined (bundle wrinkling risk)."""
    def what(faces):
        strain = faces.value("fibre")
        return 100 * strain, strain < -threshold, \
            f"shorter tow's strain\n(outlined: below -{100 * threshold:g}%)"

    return _skins(out, "fibre_compression_map.png", a, part, what, cmap="RdBu",
                  clim=(-1.0, 1.0), label="fibre strain [%]")


def conformity_map(out: Path, a: dict, bridging: float, part: Part) -> Path:
    """Gap between each skin and its tool at the end; bridged faces outlined."""
    fig, axes = _figure(2)
    for ax, name in zip(axes, ("skin_top", "skin_bottom"), strict=True):
        faces, gap, inside = a["fields"][name]
        _plan(ax, faces.polygons, np.maximum(gap, 0.0), part, cmap="magma_r",
              clim=(0.0, max(2 * bridging, float(gap[inside].max(initial=0.0)))),
              marked=inside & (gap > bridging),
              title=f"{name.replace('_', ' ')}: gap to its tool\n(outlined: above "
                    f"{bridging:g} mm inside the trim line)", label="gap [mm]")
    return _save(fig, out / "conformity_map.png")


def core_map(out: Path, a: dict, part: Part) -> Path:
    """Core thickness, the cavity's, and the volumetric plastic strain."""
    top, thickness, cavity, _inside = a["fields"]["core"]
    fig, axes = _figure(3)
    hi = float(max(thickness.max(initial=0.0), cavity.max(initial=0.0)))
    _plan(axes[0], top.polygons, thickness, part, clim=(0.0, hi),
          title="core thickness at the end", label="thickness [mm]")
    _plan(axes[1], top.polygons, cavity, part, clim=(0.0, hi),
          title="the tools' cavity, less the skins", label="thickness [mm]")
    _plan(axes[2], top.polygons, top.value("evp"), part, cmap="inferno",
          title="core crushing", label="volumetric plastic strain [-]")
    return _save(fig, out / "core_thickness_map.png")


def draw_in_map(out: Path, a: dict, part: Part) -> Path:
    """The blank's edge before and after, coloured by its in-plane motion."""
    edge, draw = a["fields"]["edge"]
    fig, (ax,) = _figure(1)
    _plan(ax, edge.polygons, draw, part, cmap="viridis", reference=True,
          title="blank edge at the end: draw-in", label="in-plane motion [mm]")
    return _save(fig, out / "draw_in_map.png")


def section_data(model) -> dict | None:
    """Section polygons of the core (with its plastic strain) and skins at y = 0."""
    from forming.post.pictures import section_polygons

    data = {}
    md = model.scene.mesh
    for name in ("core", "skin_bottom", "skin_top"):
        body = model.bodies[name]
        values = (body.cell_average(body.plastic.evp) if name == "core"
                  else np.zeros(body.n_local_cells))
        data[name] = section_polygons(body, body.domain.facet_tags,
                                      md.facet_tag_ids(f"{name}_ymin")[0], (0, 2), values)
    return data if model.comm.rank == 0 else None


def section_picture(out: Path, data: dict, model, t: float) -> Path:
    """Tools, skins and core (coloured by its crushing) in the plane y = 0, mirrored."""
    from forming.contact.render import section_plot

    polys, vals = data["core"]
    skins = [p for name in ("skin_bottom", "skin_top") for p in data[name][0]]
    tools = [(tl.name, tl.shape, tl.offset(t)) for tl in model.scene.tools]
    return section_plot(out / "section_y0.png", polys, vals, tools, (1, 0.0), (0, 2),
                        label="volumetric plastic strain [-]", mirror=True, extra=skins,
                        title="Demonstrator: section y = 0 (tools, skins dark, core)")


def _save(fig: Figure, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path
