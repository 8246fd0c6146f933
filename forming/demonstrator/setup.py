"""The demonstrator case's part: its tools, blank and trim line, and how they are placed.

A :class:`Part` is what a user gives (or the shipped component): two tool files in their
closed position, a blank outline and a trim line. :func:`matched_tools` turns it into the
scene's tools and contacts around a blank: the flat blank rests on the lower tool (its
lowest node touches it), and the upper tool starts ``clearance`` above the blank's nearest
top node and closes along -z to its closed position.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from forming.blanks import Blank
from forming.contact.surface import SurfaceTool
from forming.demonstrator.curves import closed_curve, quarter, read_points
from forming.demonstrator.geometry import Component
from forming.errors import InputError
from forming.outline import Outline
from forming.parallel import on_root
from forming.scene import Contact, Linear, Tool
from forming.tooling import generated_dir, write_once


def shipped_files(component: Component | None = None) -> dict[str, Path]:
    """The shipped component's tool and trim files, written on first use (rank 0)."""
    from forming.demonstrator.tools import tool_files

    component = component or Component()
    directory = generated_dir() / component.key()
    files = {"lower": directory / "lower.stl", "upper": directory / "upper.stl",
             "trim": directory / "trim.csv"}
    comm = MPI.COMM_WORLD

    def write() -> None:
        write_once(directory, ("lower.stl", "lower.step", "upper.stl", "upper.step",
                               "trim.csv"), lambda d: tool_files(d, component))

    on_root(comm, write, gmsh_field="component")  # the others wait for the files
    return files


@dataclass(frozen=True)
class Part:
    """A matched tool pair, a blank and a trim line.

    Attributes:
        lower: The lower tool's file (closed position).
        upper: The upper tool's file (closed position).
        scale: Factor from the tool files' units to mm.
        blank: The blank's outline, counter-clockwise (n, 2) [mm].
        trim: The trim line, counter-clockwise (m, 2) [mm].
        thickness: The blank's thickness (core and both skins) [mm].
    """

    lower: Path
    upper: Path
    scale: float
    blank: np.ndarray
    trim: np.ndarray
    thickness: float

    @classmethod
    def from_params(cls, lower: str | None, upper: str | None, scale: float,
                    blank: str | None, trim: str | None, thickness: float) -> Part:
        """The part of the case's parameters (None: the shipped component's)."""
        if (lower is None) != (upper is None):
            raise InputError("--set lower_tool", "give both lower_tool and upper_tool, or "
                             "neither (the shipped component)")
        component = Component()
        shipped = shipped_files(component) if lower is None or trim is None else {}
        lo, up = (Path(lower), Path(upper)) if lower is not None else \
            (shipped["lower"], shipped["upper"])
        if blank is None:
            hx, hy = component.blank[0] / 2, component.blank[1] / 2
            outline = np.array([(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)])
        else:
            outline = closed_curve(read_points(blank, "--set blank"), "--set blank", blank)
        trim_path = shipped["trim"] if trim is None else trim
        trim_pts = closed_curve(read_points(trim_path, "--set trim"), "--set trim",
                                str(trim_path))
        inside = Outline(tuple(map(tuple, outline)))
        if not _inside(trim_pts, np.asarray(inside.points)).all():
            raise InputError("--set trim", f"{trim_path}: the trim line leaves the blank "
                             "(it must lie inside the blank's outline)")
        return cls(lo, up, scale, outline, trim_pts, thickness)

    @property
    def quarter(self) -> Outline:
        """The modelled quarter of the blank (x >= 0, y >= 0)."""
        return quarter(self.blank, "--set blank")


def _inside(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Whether points (n, 2) lie inside the closed polygon (even-odd rule)."""
    x, y = points[:, 0][:, None], points[:, 1][:, None]
    a, b = polygon, np.roll(polygon, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    t = (y - a[:, 1]) / np.where(b[:, 1] != a[:, 1], b[:, 1] - a[:, 1], 1.0)
    return (crosses & (x < a[:, 0] + t * (b[:, 0] - a[:, 0]))).sum(axis=1) % 2 == 1


def inside_trim(part: Part, xy: np.ndarray) -> np.ndarray:
    """Whether plan points (n, 2) of the whole part lie inside the trim line."""
    return _inside(np.asarray(xy, dtype=float).reshape(-1, 2), part.trim)


def _extreme_z(tool: SurfaceTool, blank: Outline, highest: bool) -> float:
    """The tool's highest (lowest) vertex z over the blank quarter's plan bounds."""
    v = tool.surface.vertices
    x0, y0, x1, y1 = blank.bounds
    over = (v[:, 0] >= x0) & (v[:, 0] <= x1) & (v[:, 1] >= y0) & (v[:, 1] <= y1)
    if not over.any():
        raise InputError("tool.path", f"{tool.path}: no vertex over the blank's plan; are the "
                         "tools placed around the origin?")
    z = v[over, 2]
    return float(z.max() if highest else z.min())


def _node_gap(tool: SurfaceTool, blank: Blank, z: float, lift: float) -> float:
    """The smallest gap between the tool, moved up by ``lift``, and a face's nodes [mm].

    The face is the blank's nodes at height ``z``. Every rank gets the same value (the
    smallest over ranks); a tool that passes through the face (a negative gap) is refused.
    """
    x = blank.mesh.mesh.geometry.x
    face = x[np.abs(x[:, 2] - z) <= 1e-9 * max(1.0, abs(z))]
    face = face - np.array([0.0, 0.0, lift])
    local = float(tool.gap_normal(face)[0].min()) if len(face) else np.inf
    gap = blank.mesh.mesh.comm.allreduce(local, op=MPI.MIN)
    if not np.isfinite(gap) or gap < -1e-9 * max(1.0, abs(z)):
        raise InputError("tool.path", f"{tool.path}: the tool passes through the blank's "
                         f"face at z = {z:g} mm (gap {gap:.4g} mm); does it cover the blank?")
    return gap


def matched_tools(part: Part, blank: Blank, friction: float, clearance: float,
                  tolerance: float | None = None, penalty_scale: float = 1.0
                  ) -> tuple[tuple[Tool, ...], tuple[Contact, ...], float]:
    """The lower (fixed) and upper (closing) tools and their contacts with the skins.

    ``tolerance``: the contacts' admissible penetration [mm] (None: the contact's default).
    ``penalty_scale``: the contacts' :attr:`~forming.scene_contact.Contact.penalty_scale`.

    Returns:
        Tools, contacts and the closing stroke [mm].
    """
    outline = part.quarter
    lower0 = SurfaceTool(part.lower, scale=part.scale)
    upper0 = SurfaceTool(part.upper, scale=part.scale)
    extent = float(np.ptp(part.blank, axis=0).max())
    for tool in (lower0, upper0):
        tool.check_units(extent)
    shift = -_extreme_z(lower0, outline, highest=True)  # the blank rests on the lower tool
    lowest = _extreme_z(upper0, outline, highest=False) + shift
    stroke = blank.top + clearance - lowest
    if stroke <= 0:
        raise InputError("--set upper_tool", f"{part.upper}: the closed upper tool does not "
                         "reach down to the blank's top")
    # the vertices place the tools to within the sag of a tool facet between blank nodes;
    # the contacts see the nodes, so close the tools onto the nearest node of each face
    # (an open gap of 0.017 mm left the blank floating in the first step with the weaker
    # skin springs: docs/theory.md, 16)
    # (a sloped facet: the normal gap shrinks less than the move, hence a few passes)
    for _ in range(4):
        gap = _node_gap(lower0, blank, blank.bottom, shift)
        shift += gap
        if gap <= 1e-9 * blank.top:
            break
    for _ in range(4):
        gap = _node_gap(upper0, blank, blank.top, shift + stroke) - clearance
        stroke -= gap
        if abs(gap) <= 1e-9 * blank.top:
            break
    lower = SurfaceTool(part.lower, scale=part.scale, translate=(0.0, 0.0, shift))
    upper = SurfaceTool(part.upper, scale=part.scale, translate=(0.0, 0.0, shift + stroke))
    tools = (Tool("lower", lower), Tool("upper", upper, z=Linear(-stroke)))
    contacts = (Contact(blank.upper, blank.face(blank.upper, "top"), "upper",
                        friction=friction, stick="elastic_slip", tolerance=tolerance,
                        penalty_scale=penalty_scale),
                Contact(blank.lower, blank.face(blank.lower, "bottom"), "lower",
                        friction=friction, stick="elastic_slip", tolerance=tolerance,
                        penalty_scale=penalty_scale))
    return tools, contacts, stroke
