"""Rigid tools given as triangulated surfaces: STL, OBJ, PLY, gmsh meshes, STEP/IGES.

A :class:`SurfaceTool` is a tool shape like those of :mod:`forming.contact.shapes`:
a signed distance, positive outside the tool. The tool is the side its triangles'
normals point away from: a closed surface with outward normals (a punch) is the solid it
encloses; an open sheet (``sheet=True``, one working face of a die) has the tool behind
it, and ``flip=True`` turns it round.

The distance is the exact distance to the triangles. Its sign is that of ``(x - c) . n``
with ``c`` the closest point and ``n`` the angle-weighted pseudo-normal of the feature
``c`` lies on (face, edge or vertex; Baerentzen & Aanaes 2005), so it is right next to
edges and vertices too, on both faces of a sheet. The gap's normal is the distance's
gradient; the contact traction's direction is the smoothed normal of
:mod:`forming.contact.closest` (corner normals interpolated over the facet, not across
crease edges sharper than ``crease_angle``). The search and the tracking are in
:mod:`forming.contact.trisurface`. The surface is read on rank 0 and every rank holds a
copy (a tool surface of 10^6 triangles takes about 100 MB per rank).

Bad surfaces get an :class:`~forming.errors.InputError` naming the file and the fault:
unreadable, no triangles, non-manifold edges, inconsistent orientation, open where a
closed solid is declared.
"""

from __future__ import annotations

import atexit
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np
from mpi4py import MPI

from forming.cad import Tessellation, orient_outward, triangles
from forming.contact.trisurface import CREASE_DEG, LIVE, FacetTracker, TriangleSurface
from forming.errors import InputError
from forming.parallel import on_root

log = logging.getLogger(__name__)

@atexit.register
def _release_trees() -> None:
    """Free the search trees before interpreter shutdown.

    A tree still referenced from a reference cycle at exit makes nanobind (fcpw's
    bindings) print leak warnings for every bound function.
    """
    for surface in list(LIVE):
        surface.release()


_CAD = {".step", ".stp", ".iges", ".igs", ".brep"}
_MESH = {".stl", ".obj", ".ply", ".off", ".msh", ".vtk", ".vtu"}


# -- reading --------------------------------------------------------------------------
def _read_cad(path: Path, tess: Tessellation) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the faces of a CAD file with gmsh's OpenCASCADE kernel."""
    import gmsh

    started = gmsh.isInitialized()
    if not started:
        gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(f"tool_{path.stem}")
    try:
        gmsh.model.occ.importShapes(str(path))
        gmsh.model.occ.synchronize()
        tess.apply(gmsh)
        gmsh.model.mesh.generate(2)
        if 2 not in list(gmsh.model.mesh.getElements(2)[0]):
            raise InputError("tool.path", f"{path}: the CAD file has no faces to mesh")
        vertices, faces = triangles(gmsh)
    except InputError:
        raise
    except Exception as exc:  # gmsh raises a bare Exception with its log line
        raise InputError("tool.path", f"{path}: gmsh could not read or mesh it ({exc})") \
            from exc
    finally:
        gmsh.model.remove()
        if not started:
            gmsh.finalize()
    # a CAD solid's faces come in their own parametric orientations
    return vertices, orient_outward(vertices, faces)


def _read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import meshio

    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many types for a broken file
        raise InputError("tool.path", f"{path}: not a readable surface mesh ({exc})") from exc
    tris = [np.asarray(b.data, dtype=np.int64) for b in m.cells if b.type == "triangle"]
    if not tris:
        raise InputError("tool.path", f"{path}: has no triangles "
                         f"(cell types: {sorted({b.type for b in m.cells}) or 'none'})")
    return np.asarray(m.points, dtype=float)[:, :3], np.vstack(tris)


def read_triangles(path: Path, tess: Tessellation) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) and triangles (m, 3) of a surface file.

    Args:
        path: STL, OBJ, PLY, OFF, gmsh or VTK surface mesh, or a STEP/IGES/BREP model.
        tess: How finely a CAD model is triangulated (sizes in the file's units).
    """
    suffix = path.suffix.lower()
    if suffix not in _CAD | _MESH:
        raise InputError("tool.path", f"{path}: unknown surface format {suffix!r} "
                         f"(one of {', '.join(sorted(_CAD | _MESH))})")
    if not path.is_file():
        raise InputError("tool.path", f"{path}: no such file")
    return _read_cad(path, tess) if suffix in _CAD else _read_mesh(path)


# -- topology and checks ----------------------------------------------------------------
def _load(tool: SurfaceTool, comm: MPI.Comm) -> TriangleSurface:
    """Read on rank 0, broadcast, check and build on every rank (errors on every rank)."""
    path, scale, tess = tool.path, tool.scale, tool.tessellation
    data = on_root(comm, lambda: read_triangles(
        path, Tessellation(tess.angle, tess.max_size / scale)))
    vertices, faces = comm.bcast(data, root=0)
    vertices = vertices * scale + np.asarray(tool.translate, dtype=float)
    if tool.flip:
        faces = faces[:, [0, 2, 1]]
    return TriangleSurface(vertices, faces, str(path), tool.sheet, tool.crease_angle)


@dataclass(frozen=True)
class SurfaceTool:
    """A rigid tool given by a triangulated surface file (see the module docstring).

    Attributes:
        path: The surface file.
        sheet: The surface is one open working face, not a closed solid.
        flip: Turn the triangles round (the tool is on the other side).
        scale: Factor from the file's units to mm (1000 for a file in metres).
        translate: Moved by this after scaling [mm].
        tessellation: How finely a CAD model is triangulated (sizes in mm).
        crease_angle: Edges whose faces meet at more than this are sharp: the contact
            traction's direction is smoothed over the others only [deg].
    """

    tracked: ClassVar[bool] = True  # no UFL expression: the contact tracks closest points

    path: Path
    sheet: bool = False
    flip: bool = False
    scale: float = 1.0
    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tessellation: Tessellation = Tessellation()
    crease_angle: float = CREASE_DEG
    surface: TriangleSurface = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise InputError("tool.scale", f"must be a positive number, got {self.scale!r}")
        if not (0.0 <= self.crease_angle <= 180.0):
            raise InputError("tool.crease_angle", f"must be in [0, 180] degrees, got "
                             f"{self.crease_angle!r}")
        object.__setattr__(self, "surface", _load(self, MPI.COMM_WORLD))

    def distance(self, p, xp):
        """Signed distance of the (3, ...) points ``p`` (NumPy only)."""
        if not isinstance(p, np.ndarray):
            raise TypeError(f"{self.path}: a surface tool's distance is not a UFL expression")
        d = self.surface.query(p.reshape(3, -1).T).distance
        return d.reshape(p.shape[1:])

    def gap_normal(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) and traction direction (n, 3) of the (n, 3) points."""
        q = self.surface.query(points)
        return q.distance, q.direction

    def tracker(self) -> FacetTracker:
        """A closest-point tracker for points that move a little between queries."""
        return FacetTracker(self.surface)

    def polydata(self):
        """The triangles as a :class:`pyvista.PolyData` (outputs, pictures)."""
        import pyvista

        s = self.surface
        cells = np.hstack([np.full((len(s.faces), 1), 3), s.faces]).ravel()
        return pyvista.PolyData(s.vertices.copy(), cells)

    @property
    def search_seconds(self) -> float:
        """Time spent in closest-point queries so far [s]."""
        return self.surface.seconds

    def check_units(self, extent: float) -> None:
        """Refuse a surface whose size is far off the blank's ``extent`` [mm]."""
        ratio = self.surface.extent / extent
        if not 1e-2 <= ratio <= 1e3:
            raise InputError("tool.scale", f"{self.path}: the surface is {self.surface.extent:.4g}"
                             f" mm across, the blank {extent:.4g} mm: are its units mm? "
                             "(scale converts them)")
