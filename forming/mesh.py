"""Meshes built with gmsh, with named physical groups for every body and face."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mpi4py import MPI

from forming import compat
from forming.errors import InputError
from forming.parallel import on_root
from forming.partition import Partition


@dataclass(frozen=True)
class MeshData:
    """A DOLFINx mesh with its tags and the names of its physical groups.

    Attributes:
        mesh: The DOLFINx mesh.
        cell_tags: Volume physical groups.
        facet_tags: Surface physical groups (disjoint: one tag per facet).
        names: Physical group name -> (dimension, tag).
        unions: Facet group name -> tags of the disjoint facet groups it is made of
            (overlapping groups, such as all lateral faces of a sandwich).
    """

    mesh: object
    cell_tags: object
    facet_tags: object
    names: dict[str, tuple[int, int]]
    unions: dict[str, tuple[int, ...]] = field(default_factory=dict)

    def facets(self, name: str) -> np.ndarray:
        """Local facet indices of the surface group ``name`` (disjoint group or union)."""
        found = [self.facet_tags.find(t) for t in self.facet_tag_ids(name)]
        return np.unique(np.concatenate(found)).astype(np.int32)

    def facet_tag_ids(self, name: str) -> tuple[int, ...]:
        """Facet tags of the surface group ``name`` (for ``ds(subdomain_id=...)``).

        Raises:
            InputError: No surface group of that name.
        """
        if name in self.names and self.names[name][0] == 2:
            return (self.names[name][1],)
        if name in self.unions:
            return self.unions[name]
        known = sorted({n for n, (d, _t) in self.names.items() if d == 2} | set(self.unions))
        raise InputError("region", f"no 2D physical group {name!r}; known: {known}")

    def cells(self, name: str) -> np.ndarray:
        """Local cell indices of the volume group ``name``."""
        dim, tag = self._lookup(name, 3)
        return self.cell_tags.find(tag)

    def _lookup(self, name: str, dim: int) -> tuple[int, int]:
        if name not in self.names or self.names[name][0] != dim:
            known = sorted(n for n, (d, _t) in self.names.items() if d == dim)
            raise InputError("region", f"no {dim}D physical group {name!r}; known: {known}")
        return self.names[name]

    @property
    def min_cell_size(self) -> float:
        """Smallest cell diameter over all ranks [mm]."""
        msh = self.mesh
        tdim = msh.topology.dim
        n = msh.topology.index_map(tdim).size_local
        h = msh.h(tdim, np.arange(n, dtype=np.int32))
        local = float(h.min()) if n else np.inf
        return msh.comm.allreduce(local, op=MPI.MIN)


def bounding_box(msh) -> np.ndarray:
    """Reference bounding box of a DOLFINx mesh over all ranks: rows min xyz, max xyz [mm].

    Collective; a rank without nodes takes no part in the extremes.
    """
    x = msh.geometry.x
    comm = msh.comm
    lo = [comm.allreduce(float(x[:, i].min(initial=np.inf)), op=MPI.MIN) for i in range(3)]
    hi = [comm.allreduce(float(x[:, i].max(initial=-np.inf)), op=MPI.MAX) for i in range(3)]
    return np.array([lo, hi])


def mesh_from_gmsh(gmsh, comm, partition: Partition = "graph") -> MeshData:
    """The DOLFINx mesh, tags and group names of the current gmsh model.

    ``partition`` shares the cells among the ranks (:mod:`forming.partition`).
    """
    data = compat.model_to_mesh(gmsh.model, comm, 0, gdim=3, partition=partition)
    names = {name: (pg.dim, pg.tag) for name, pg in data.physical_groups.items()}
    return MeshData(data.mesh, data.cell_tags, data.facet_tags, names)


_FACES = {"xmin": (0, 0), "xmax": (0, 1), "ymin": (1, 0), "ymax": (1, 1),
          "bottom": (2, 0), "top": (2, 1)}


@dataclass(frozen=True)
class Block:
    """A structured hexahedral block of a mesh (see :func:`box` and :func:`blocks`).

    Attributes:
        name: Name of its volume group.
        size: Edge lengths (x, y, z) [mm], all positive.
        cells: Number of hexahedra along x, y, z, all >= 1.
        origin: Corner with the smallest coordinates.
        grading: Per-axis ratio of consecutive cell sizes along +x, +y, +z (1: uniform;
            > 1 refines towards the low side, < 1 towards the high side).
        warp: Map of the block's node coordinates, ``(n, 3) -> (n, 3)``, applied after
            meshing (a die with a curved face, say); faces keep their names.
    """

    name: str
    size: tuple[float, float, float]
    cells: tuple[int, int, int]
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    grading: tuple[float, float, float] = (1.0, 1.0, 1.0)
    warp: Callable[[np.ndarray], np.ndarray] | None = None

    def __post_init__(self) -> None:
        if len(self.size) != 3 or any(not np.isfinite(s) or s <= 0 for s in self.size):
            raise InputError("mesh.size", f"edge lengths must be three positive numbers, "
                             f"got {self.size}")
        if len(self.cells) != 3 or any(int(n) != n or n < 1 for n in self.cells):
            raise InputError("mesh.cells", f"cell counts must be three integers >= 1, got "
                             f"{self.cells}")
        if len(self.grading) != 3 or any(not np.isfinite(g) or g <= 0 for g in self.grading):
            raise InputError("mesh.grading", f"must be three positive ratios, got "
                             f"{self.grading}")


def _add_block(gmsh, block: Block) -> tuple[int, dict[str, list[int]]]:
    """Add a transfinite box to the gmsh model; its volume tag and its faces' tags."""
    vol = gmsh.model.occ.addBox(*block.origin, *block.size)
    gmsh.model.occ.synchronize()
    _up, surfaces = gmsh.model.getAdjacencies(3, vol)
    for surf in surfaces:
        for curve in gmsh.model.getAdjacencies(2, surf)[1]:
            lo = gmsh.model.getBoundingBox(1, curve)
            axis = int(np.argmax(np.abs(np.array(lo[3:]) - np.array(lo[:3]))))
            lo_t, hi_t = gmsh.model.getParametrizationBounds(1, curve)
            x0 = gmsh.model.getValue(1, curve, [lo_t[0]])[axis]
            x1 = gmsh.model.getValue(1, curve, [hi_t[0]])[axis]
            g = block.grading[axis]
            gmsh.model.mesh.setTransfiniteCurve(curve, int(block.cells[axis]) + 1,
                                                "Progression", g if x1 > x0 else 1.0 / g)
        gmsh.model.mesh.setTransfiniteSurface(surf)
        gmsh.model.mesh.setRecombine(2, surf)
    gmsh.model.mesh.setTransfiniteVolume(vol)
    faces = {}
    for fname, (axis, side) in _FACES.items():
        coord = block.origin[axis] + side * block.size[axis]
        faces[fname] = [s for s in surfaces if abs(gmsh.model.occ.getCenterOfMass(2, s)[axis]
                                                   - coord) < 1e-9 * max(block.size)]
    return vol, faces


def _warp(gmsh, vol: int, block: Block) -> None:
    """Move the nodes of a meshed block (its volume and boundary) by ``block.warp``."""
    tags, coords, _p = gmsh.model.mesh.getNodes(3, vol, includeBoundary=True)
    tags, first = np.unique(tags, return_index=True)
    x = np.asarray(coords).reshape(-1, 3)[first]
    y = np.asarray(block.warp(x.copy()), dtype=float)
    if y.shape != x.shape or not np.all(np.isfinite(y)):
        raise InputError("mesh.warp", f"block {block.name!r}: the map must return finite "
                         f"coordinates of shape {x.shape}")
    for t, p in zip(tags, y, strict=True):
        gmsh.model.mesh.setNode(int(t), p.tolist(), [])


def blocks(parts: list[Block], comm: MPI.Comm = MPI.COMM_WORLD,
           partition: Partition = "graph") -> MeshData:
    """Disjoint structured blocks in one mesh, each meshed on its own.

    Blocks that touch share no nodes (their meshes need not match): two bodies in
    contact with finite sliding, such as a fabric layer on a core. Groups: each block's
    volume by its name and its faces as ``<name>_<face>`` (faces ``xmin, xmax, ymin,
    ymax, bottom, top``). ``partition``: :mod:`forming.partition`.
    """
    if len({b.name for b in parts}) != len(parts):
        raise InputError("mesh.blocks", "block names must be distinct")
    return _generate(parts, comm, prefix=True, partition=partition)


def box(
    size: tuple[float, float, float],
    cells: tuple[int, int, int],
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    name: str = "core",
    comm: MPI.Comm = MPI.COMM_WORLD,
    grading: tuple[float, float, float] = (1.0, 1.0, 1.0),
    partition: Partition = "graph",
) -> MeshData:
    """Structured hexahedral block with faces ``xmin, xmax, ymin, ymax, bottom, top``.

    Args:
        size: Edge lengths (x, y, z) [mm], all positive.
        cells: Number of hexahedra along x, y, z, all >= 1.
        origin: Corner with the smallest coordinates.
        name: Name of the volume group.
        comm: Communicator of the mesh.
        grading: Per-axis ratio of consecutive cell sizes along +x, +y, +z (1: uniform;
            > 1 refines towards the low side, < 1 towards the high side).
        partition: How the cells are shared among the ranks (:mod:`forming.partition`).
    """
    return _generate([Block(name, size, cells, origin, grading)], comm, prefix=False,
                     partition=partition)


def _generate(parts: list[Block], comm: MPI.Comm, prefix: bool,
              partition: Partition = "graph") -> MeshData:
    import gmsh

    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("_".join(b.name for b in parts))

    def build() -> None:
        tag = 1
        volumes = []
        for i, block in enumerate(parts, start=1):
            vol, faces = _add_block(gmsh, block)
            volumes.append(vol)
            gmsh.model.addPhysicalGroup(3, [vol], i, name=block.name)
            for fname, ents in faces.items():
                gmsh.model.addPhysicalGroup(
                    2, ents, tag, name=f"{block.name}_{fname}" if prefix else fname)
                tag += 1
        gmsh.model.mesh.generate(3)
        for block, vol in zip(parts, volumes, strict=True):
            if block.warp is not None:
                _warp(gmsh, vol, block)

    try:
        on_root(comm, build, gmsh_field="mesh")
        return mesh_from_gmsh(gmsh, comm, partition)
    finally:
        gmsh.model.remove()
        if not initialised:
            gmsh.finalize()


def from_file(path: str | Path, comm: MPI.Comm = MPI.COMM_WORLD) -> MeshData:
    """Read a gmsh ``.msh`` file with physical groups.

    Raises:
        InputError: The file does not exist or is not a gmsh mesh.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("mesh.path", f"file not found: {p}")
    import gmsh

    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)

    def read() -> None:
        try:
            gmsh.open(str(p))
        except Exception as exc:  # gmsh raises a bare Exception
            raise InputError("mesh.path", f"gmsh cannot read {p}: {exc}") from exc

    try:
        on_root(comm, read)
        return mesh_from_gmsh(gmsh, comm)
    finally:
        gmsh.clear()
        if not initialised:
            gmsh.finalize()
