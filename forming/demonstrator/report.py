"""What the demonstrator reports: metrics, plots and pictures a process engineer reads.

All from the formed blank's boundary faces (:mod:`forming.demonstrator.final`), measured
on rank 0 and broadcast; areas and volumes are for the whole part (the quarter model
times four); maps show the whole part, mirrored.

- **Shear**: each skin's cell shear angles on its tool-side faces; the area beyond the
  wrinkling angles (+42 / -50 deg for FCIM359) and the fibre-compression area (the
  shorter tow strained below ``-FIBRE_COMPRESSION``).
- **Conformity**: the gap between each skin's tool-side faces and its tool at the end;
  a face farther than ``bridging_gap`` inside the trim line bridges.
- **Core**: the thickness at each face of the core's top (distance to its bottom
  faces), against the cavity's (the distances to both tools, less the skins); the
  crushed volume and the volumetric plastic strain.
- **Draw-in**: how far the blank's free edge moved in plan.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forming import post
from forming.blanks import SKINS, Blank
from forming.demonstrator.final import Faces, boundary_faces, implicit_distance
from forming.demonstrator.setup import Part, inside_trim

FIBRE_COMPRESSION = 0.01  # a tow strained below minus this is compressed [-]
TOOL_OF = {"skin_top": "upper", "skin_bottom": "lower"}
FORMING_MAP = "forming_map.npz"  # core mid-surface before and after, edge, trim, blank


@dataclass(frozen=True)
class Report:
    """The demonstrator's metrics, plots and pictures for one part and blank.

    Attributes:
        part: The part (tools, blank outline, trim line).
        blank: The blank's bodies and faces.
        stroke: The upper tool's closing stroke [mm].
        bridging_gap: A skin farther than this from its tool bridges [mm].
        core: The blank's core thickness [mm].
        limits: The fabric's wrinkling angles (positive, negative) [deg].
    """

    part: Part
    blank: Blank
    stroke: float
    bridging_gap: float
    core: float
    limits: tuple[float, float] = (42.0, -50.0)
    _state: dict = field(default_factory=dict, compare=False, repr=False)

    # -- gathering ------------------------------------------------------------------------
    def _gather(self, model, t: float) -> dict | None:
        """Faces of every body and the tools' final surfaces (collective; rank 0)."""
        faces = {}
        for name in SKINS:
            body = model.bodies[name]
            body.update_output()
            n = body.n_local_cells
            faces[name] = boundary_faces(body, {
                "shear": body.shear_angle.x.array[:n].copy(),
                "fibre": body.fibre_strain.x.array[:n].copy()})
        core = model.bodies["core"]
        faces["core"] = boundary_faces(core, {"evp": core.cell_average(core.plastic.evp)})
        if model.comm.rank != 0:
            return None
        tools = {}
        for tool in model.scene.tools:
            pd = tool.shape.polydata()
            pd.translate(tool.offset(t), inplace=True)
            tools[tool.name] = pd
        return {"faces": faces, "tools": tools, "t": t}

    def _analyse(self, g: dict) -> dict:
        """The measured fields and figures (rank 0)."""
        out: dict = {"fields": {}}
        m: dict[str, float] = {}
        skin = (self.blank.top - self.blank.bottom - self.core) / 2
        bridged, gap_max, where = 0.0, 0.0, (np.nan, np.nan)
        for name in SKINS:
            f: Faces = g["faces"][name]
            side = f.up() if name == "skin_top" else f.down()
            gap = implicit_distance(side.centres, g["tools"][TOOL_OF[name]])
            inside = inside_trim(self.part, side.centres[:, :2])
            out["fields"][name] = (side, gap, inside)
            over = inside & (gap > self.bridging_gap)
            bridged += 4.0 * float(side.areas[over].sum())
            m[f"conformity_gap_max_mm_{name}"] = float(gap[inside].max(initial=0.0))
            if m[f"conformity_gap_max_mm_{name}"] > gap_max:
                gap_max = m[f"conformity_gap_max_mm_{name}"]
                where = tuple(side.centres[inside][np.argmax(gap[inside])][:2])
            fibre = side.value("fibre")
            m[f"fibre_compression_area_fraction_{name}"] = float(
                side.areas[fibre < -FIBRE_COMPRESSION].sum() / side.areas.sum())
        m |= {"bridged_area_mm2": bridged, "conformity_gap_max_mm": gap_max,
              "conformity_gap_max_x_mm": float(where[0]),
              "conformity_gap_max_y_mm": float(where[1])}
        core: Faces = g["faces"]["core"]
        top, bottom = core.up(), core.down()
        thickness = np.abs(implicit_distance(top.centres, bottom.polydata()))
        cavity = (np.abs(implicit_distance(top.centres, g["tools"]["upper"]))
                  + np.abs(implicit_distance(top.centres, g["tools"]["lower"])) - 2 * skin)
        inside = inside_trim(self.part, top.centres[:, :2])
        out["fields"]["core"] = (top, thickness, cavity, inside)
        out["fields"]["core_bottom"] = bottom
        m["core_thickness_min_mm"] = float(thickness[inside].min(initial=np.inf))
        m["core_underfill_max_mm"] = float((cavity - thickness)[inside].max(initial=0.0))
        edge = core.lateral()
        free = (edge.reference_centres[:, 0] > 1e-6) & (edge.reference_centres[:, 1] > 1e-6)
        edge = edge.select(free)
        draw = np.linalg.norm((edge.centres - edge.reference_centres)[:, :2], axis=1)
        out["fields"]["edge"] = (edge, draw)
        m["edge_draw_in_max_mm"] = float(draw.max(initial=0.0))
        out["metrics"] = m
        return out

    def _measure(self, model, t: float) -> dict:
        """The analysis of ``model`` at load ``t``, once (collective; full on rank 0).

        The metrics and pictures hooks share it. It is kept for one model and one load:
        ``forming compare`` runs both solvers from one job (one report), and the explicit
        run must not be shown the implicit run's fields.
        """
        st = self._state
        held = st.get("model")
        if held is None or held() is not model or st.get("measured_at") != t:
            g = self._gather(model, t)
            st |= {"model": weakref.ref(model), "measured_at": t,
                   "analysis": self._analyse(g) if g is not None else None}
        return st["analysis"]

    def _write_forming_map(self, out: Path, a: dict) -> None:
        """``forming_map.npz``: the core's mid-surface and blank edge, before and after."""
        top, bottom = a["fields"]["core"][0], a["fields"]["core_bottom"]
        edge = a["fields"]["edge"][0]
        # the forming map of the core's mid-surface: a sheared blank edge (skin-core slip
        # tilts it) then straddles the trim line instead of leaving it on one side
        np.savez(out / FORMING_MAP, reference=top.reference, current=top.midway(bottom),
                 edge_reference=edge.reference, edge_current=edge.polygons,
                 trim=self.part.trim, blank=self.part.blank)

    # -- the case's hooks -----------------------------------------------------------------
    def metrics(self, rec, model) -> dict:
        """Shear, wrinkling, conformity, crushing, draw-in and force figures (collective)."""
        t = float(rec.column("t")[-1])
        self._state["t"] = t
        a = self._measure(model, t)
        if a is not None:  # rank 0: the map the blank optimisation reads (pictures or not)
            self._write_forming_map(Path(rec.out), a)
        mine = a["metrics"] if a is not None else None
        mine = model.comm.bcast(mine, root=0)
        force = rec.column("force_upper_z_N")
        return (post.skin_shear_statistics(model, SKINS) | post.interface_slips(model)
                | post.contact_metrics(rec, model) | mine
                | {"closing_force_max_N": float(np.abs(force).max()),
                   "crushed_volume_mm3": post.crushed_volume(model),
                   "stroke_mm": self.stroke, "closed_fraction": t})

    def plots(self, rec, out: Path) -> list[Path]:
        """The closing force against the stroke."""
        return post.force_travel_plot(rec, out, "force_upper_z_N", self.stroke, 4,
                                      "Demonstrator: closing the tools", "closing force",
                                      "closing_force.png")

    def pictures(self, model, out: Path) -> list[Path]:
        """Shear, fibre, conformity, core, draw-in maps and the section (collective)."""
        from forming.demonstrator import maps

        a = self._measure(model, self._state.get("t", 1.0))
        section = maps.section_data(model)
        if model.comm.rank != 0:
            return []
        out = Path(out)
        return [maps.shear_map(out, a, self.limits, self.part),
                maps.fibre_map(out, a, FIBRE_COMPRESSION, self.part),
                maps.conformity_map(out, a, self.bridging_gap, self.part),
                maps.core_map(out, a, self.part),
                maps.draw_in_map(out, a, self.part),
                maps.section_picture(out, section, model, self._state.get("t", 1.0))]
