"""The paper's tool sets around a blank: tools, their load paths and contact pairs.

Each builder takes a :class:`~forming.blanks.Blank` (a core alone or a sandwich), so the
same tooling serves the core, the sandwich and, later, meso-scale blanks.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Literal

import numpy as np
from mpi4py import MPI

from forming.blanks import Blank
from forming.cad import HemisphereToolSet, Tessellation, hemisphere_tool_files
from forming.contact.shapes import AnnularPlate, HemisphericalPunch
from forming.contact.surface import SurfaceTool
from forming.parallel import on_root
from forming.scene import Contact, Linear, Tool

Stick = Literal["augmented", "elastic_slip"]
Source = Literal["analytic", "stl", "step"]

PUNCH_LENGTH = 150.0  # shank above the hemisphere [mm]


def generated_dir() -> Path:
    """Where generated tool files go: ``$FORMING_MESH_CACHE`` or ``meshes/generated``."""
    env = os.environ.get("FORMING_MESH_CACHE")
    return Path(env) if env else Path(__file__).resolve().parents[1] / "meshes" / "generated"


def write_once(directory: Path, names: tuple[str, ...],
               writer: Callable[[Path], None]) -> None:
    """Fill ``directory`` with the files ``names`` by ``writer``, unless they are all there.

    The files are written into a fresh sibling folder that is then renamed into place, so
    a run (or a test worker) that finds the folder finds it complete: two processes that
    generate the same tools at once each write their own copy, the first rename wins and
    the other copy is discarded.
    """
    if all((directory / n).is_file() for n in names):
        return
    directory.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f".{directory.name}.", dir=directory.parent))
    try:
        writer(scratch)
        missing = [n for n in names if not (scratch / n).is_file()]
        if missing:
            raise RuntimeError(f"writing {directory} did not give {', '.join(missing)}")
        scratch.chmod(0o755)  # mkdtemp's folder is the owner's alone; the tools are not
        if directory.exists() and not all((directory / n).is_file() for n in names):
            shutil.rmtree(directory, ignore_errors=True)  # an incomplete folder of old
        try:
            scratch.rename(directory)
        except OSError:
            if not all((directory / n).is_file() for n in names):
                raise  # not another writer's complete copy: a real failure
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _surface_tools(tools: HemisphereToolSet, source: Source, tess: Tessellation,
                   top: float, bottom: float) -> dict[str, SurfaceTool]:
    """The hemisphere tools read back from generated STL or STEP files, placed."""
    comm = MPI.COMM_WORLD
    directory = generated_dir() / "tools" / tools.key(tess)

    def write() -> None:
        write_once(directory, tuple(f"{n}{s}" for n in ("punch", "die", "holder")
                                    for s in (".stl", ".step")),
                   lambda d: hemisphere_tool_files(d, tools, tess))

    on_root(comm, write, gmsh_field="tools")  # the others wait for the files
    suffix = ".stl" if source == "stl" else ".step"
    return {name: SurfaceTool(directory / f"{name}{suffix}", translate=(0.0, 0.0, z),
                              tessellation=tess)
            for name, z in (("punch", top), ("die", bottom), ("holder", top))}


def hemisphere_tools(blank: Blank, punch_diameter: float = 100.0, die_diameter: float = 144.0,
                     edge_radius: float = 10.0, stroke: float = 50.0, friction: float = 0.36,
                     holder: bool = False, stick: Stick = "augmented",
                     source: Source = "analytic", tessellation: Tessellation | None = None
                     ) -> tuple[tuple[Tool, ...], tuple[Contact, ...]]:
    """Hemispherical punch, die with a round opening and optional blank holder.

    The paper's "Core bending" set (Fig. 10): the punch travels ``stroke`` down from the
    blank's top; die and holder are fixed annular plates with edge radius
    ``edge_radius`` around an opening of ``die_diameter``.

    ``source="stl"`` or ``"step"`` gives the same tools as surface meshes
    (:mod:`forming.contact.surface`): solids built with OpenCASCADE, written once under
    :func:`generated_dir` (``forming.cad``), read back from their STL triangles or meshed
    again from STEP; die and holder are then discs reaching 40 mm beyond the blank's
    farthest corner.

    Returns:
        The tools (punch, die, holder) and the contacts of the blank's upper and lower
        bodies with them.
    """
    hole = die_diameter / 2
    shapes = {"punch": HemisphericalPunch((0.0, 0.0, blank.top), punch_diameter / 2,
                                          length=PUNCH_LENGTH),
              "die": AnnularPlate((0.0, 0.0, blank.bottom), hole, edge_radius, side=-1),
              "holder": AnnularPlate((0.0, 0.0, blank.top), hole, edge_radius, side=1)}
    if source != "analytic":
        x = blank.mesh.mesh.geometry.x
        reach = float(np.hypot(x[:, 0], x[:, 1]).max()) if len(x) else 0.0
        plate = blank.mesh.mesh.comm.allreduce(reach, op=MPI.MAX) + 40.0
        shapes = _surface_tools(
            HemisphereToolSet(punch_diameter / 2, PUNCH_LENGTH, hole, edge_radius, plate),
            source, tessellation or Tessellation(), blank.top, blank.bottom)
    tools = [Tool("punch", shapes["punch"], z=Linear(-stroke)), Tool("die", shapes["die"])]
    top, bottom = blank.face(blank.upper, "top"), blank.face(blank.lower, "bottom")
    contacts = [Contact(blank.upper, top, "punch", friction=friction, stick=stick),
                Contact(blank.lower, bottom, "die", friction=friction, stick=stick)]
    if holder:
        tools.append(Tool("holder", shapes["holder"]))
        contacts.append(Contact(blank.upper, top, "holder", friction=friction, stick=stick))
    return tuple(tools), tuple(contacts)
