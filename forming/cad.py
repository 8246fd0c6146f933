"""Tool solids built with gmsh's OpenCASCADE kernel, written as STEP and STL.

The hemisphere case's punch, die and blank holder as CAD solids, so that the
surface-mesh tools (:mod:`forming.contact.surface`) can be checked against the analytic
shapes they replace, and a template for tools of any shape: build the solid, then
:func:`write_tool` meshes its boundary, orients the triangles outward and writes both
files.

Each solid is built in its own frame: the punch with its tip at the origin pointing
down, the die with its working face at z = 0 and the plate below, the holder with its
face at z = 0 and the plate above. A case places them with ``SurfaceTool.translate``.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forming.errors import InputError


@dataclass(frozen=True)
class Tessellation:
    """How finely a tool's faces are triangulated.

    Attributes:
        angle: Largest angle a triangle edge spans on a curved face [deg]; the chord
            error on a radius R is R (1 - cos(angle / 2)).
        max_size: Largest triangle edge, on flat faces [mm].
    """

    angle: float = 5.0
    max_size: float = 25.0

    def __post_init__(self) -> None:
        if not (0.0 < self.angle <= 45.0):
            raise InputError("tool_angle", f"must be in (0, 45] degrees, got {self.angle!r}")
        if not (math.isfinite(self.max_size) and self.max_size > 0.0):
            raise InputError("tool_max_size", f"must be positive, got {self.max_size!r}")

    def apply(self, gmsh) -> None:
        """Set gmsh's size options."""
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", max(3, round(360.0 / self.angle)))
        gmsh.option.setNumber("Mesh.MeshSizeMax", self.max_size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)


def orient_outward(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces of a closed surface turned so that every normal points outward.

    Neighbouring triangles are made consistent across shared edges (breadth first),
    then all are flipped if the enclosed volume comes out negative.
    """
    faces = faces.copy()
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(a, b) * (int(a.max()) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    pairs = {}
    ks = key[order]
    for i in range(len(order) - 1):
        if ks[i] == ks[i + 1]:
            e1, e2 = order[i] // 3, order[i + 1] // 3
            u, w = int(a[order[i]]), int(b[order[i]])
            pairs.setdefault(e1, []).append((e2, u, w))
            pairs.setdefault(e2, []).append((e1, u, w))

    def forward(f: int, u: int, w: int) -> bool:
        """Whether face f (as it is now) runs from vertex u to vertex w."""
        k = int(np.flatnonzero(faces[f] == u)[0])
        return bool(faces[f, (k + 1) % 3] == w)

    seen = np.zeros(len(faces), dtype=bool)
    for start in range(len(faces)):
        if seen[start]:
            continue
        seen[start] = True
        queue = deque([start])
        while queue:
            f = queue.popleft()
            for g, u, w in pairs.get(f, ()):
                if seen[g]:
                    continue
                # consistent: the shared edge runs opposite ways in f and g
                if forward(f, u, w) == forward(g, u, w):
                    faces[g] = faces[g, [0, 2, 1]]
                seen[g] = True
                queue.append(g)
    p = vertices[faces]
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    return faces[:, [0, 2, 1]] if volume < 0 else faces


def triangles(gmsh) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of the current gmsh model's 2D mesh (used nodes only)."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    types, _e, nodes = gmsh.model.mesh.getElements(2)
    tri = np.asarray(nodes[list(types).index(2)], dtype=np.int64).reshape(-1, 3)
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    used, faces = np.unique(index[tri], return_inverse=True)
    return np.asarray(coords, dtype=float).reshape(-1, 3)[used], faces.reshape(-1, 3)


@contextlib.contextmanager
def _quiet_stdout():
    """Silence OpenCASCADE's STEP writer, which prints to the C-level stdout."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


@contextlib.contextmanager
def gmsh_session():
    """gmsh, initialised quietly for the block (and finalised after it if it was not before)."""
    import gmsh

    started = gmsh.isInitialized()
    if not started:
        gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        yield gmsh
    finally:
        if not started:
            gmsh.finalize()


def write_tool(gmsh, stem: Path, tess: Tessellation) -> tuple[Path, Path]:
    """Write the current gmsh model as ``stem.step`` and its triangulation as ``stem.stl``."""
    import meshio

    stem.parent.mkdir(parents=True, exist_ok=True)
    step = stem.with_suffix(".step")
    with _quiet_stdout():
        gmsh.write(str(step))
    tess.apply(gmsh)
    gmsh.model.mesh.generate(2)
    vertices, faces = triangles(gmsh)
    faces = orient_outward(vertices, faces)
    stl = stem.with_suffix(".stl")
    meshio.write(stl, meshio.Mesh(vertices, [("triangle", faces)]), binary=True)
    return step, stl


def _circle_at(gmsh, radius: float, z: float) -> list[int]:
    e = 1e-3 * radius
    return [t for _d, t in gmsh.model.getEntitiesInBoundingBox(
        -radius - e, -radius - e, z - e, radius + e, radius + e, z + e, 1)]


@dataclass(frozen=True)
class HemisphereToolSet:
    """The hemisphere case's tools as solids (the analytic shapes' dimensions) [mm].

    Attributes:
        punch_radius: Radius of the punch's hemisphere and shank.
        punch_length: Length of the shank above the hemisphere.
        hole_radius: Radius of the die's (and holder's) opening wall.
        edge_radius: Fillet radius of the opening's edge.
        plate_radius: Outer radius of die and holder (the analytic plates are unbounded).
        thickness: Thickness of die and holder.
    """

    punch_radius: float
    punch_length: float
    hole_radius: float
    edge_radius: float
    plate_radius: float
    thickness: float = 50.0

    def key(self, tess: Tessellation) -> str:
        """A directory name that changes with every dimension and the tessellation."""
        values = (*vars(self).values(), tess.angle, tess.max_size)
        return "hemisphere-" + "-".join(f"{v:g}" for v in values)


def hemisphere_tool_files(directory: Path, tools: HemisphereToolSet,
                          tess: Tessellation) -> dict[str, Path]:
    """STEP and STL of the hemisphere case's punch, die and holder, in their own frames.

    Args:
        directory: Where to write ``punch``, ``die`` and ``holder`` (.step, .stl).
        tools: Their dimensions.
        tess: The triangulation's fineness.

    Returns:
        The STL path of each tool.
    """
    punch_radius, punch_length = tools.punch_radius, tools.punch_length
    hole_radius, edge_radius = tools.hole_radius, tools.edge_radius
    plate_radius, thickness = tools.plate_radius, tools.thickness
    out = {}
    with gmsh_session() as gmsh:
        occ = gmsh.model.occ
        gmsh.model.add("punch")
        R = punch_radius
        sphere = occ.addSphere(0, 0, R, R)
        shank = occ.addCylinder(0, 0, R, 0, 0, punch_length, R)
        occ.fuse([(3, sphere)], [(3, shank)])
        occ.synchronize()
        out["punch"] = write_tool(gmsh, directory / "punch", tess)[1]
        gmsh.model.remove()
        for name, side in (("die", -1), ("holder", 1)):
            gmsh.model.add(name)
            z0 = -thickness if side < 0 else 0.0
            plate = occ.addCylinder(0, 0, z0, 0, 0, thickness, plate_radius)
            hole = occ.addCylinder(0, 0, z0 - 1, 0, 0, thickness + 2, hole_radius)
            (solid,), _m = occ.cut([(3, plate)], [(3, hole)])
            occ.synchronize()
            occ.fillet([solid[1]], _circle_at(gmsh, hole_radius, 0.0), [edge_radius])
            occ.synchronize()
            out[name] = write_tool(gmsh, directory / name, tess)[1]
            gmsh.model.remove()
    return out
