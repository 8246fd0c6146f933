"""Where a body lives: its own mesh, and the measures its forms use on the scene mesh.

A scene with one body covering the whole mesh solves on that mesh. A body that is a
volume group of a larger mesh (a skin or the core of a sandwich blank) gets a cell
submesh with its own displacement space; its residual is still integrated on the
parent mesh (``dx`` restricted to its cells), so that it can share a form with the
interface terms on the parent's interior facets (``docs/theory.md``, "Several bodies").
Post-processing integrals use the body's own mesh (:meth:`BodyDomain.own_dx`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem, mesh  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.errors import InputError
from forming.mesh import MeshData


@dataclass(frozen=True)
class CellLayout:
    """Where the entries of a state array live: blocks of values per cell of a body's mesh.

    A checkpoint on disk stores such an array cell by cell, keyed by the original index
    of the scene-mesh cell (the mesh generator's numbering), so that it can be read back
    on another partition or number of ranks (:mod:`forming.restart`).

    Attributes:
        keys: Partition-independent key of every local cell (owned, then ghost): the
            original index of its scene-mesh cell.
        n_owned: Number of owned cells (the first ``n_owned`` keys).
        entries: (cells, blocks per cell): each cell's blocks in the array.
        bs: Values per block.
        shape: Shape of the whole local array.
    """

    keys: np.ndarray
    n_owned: int
    entries: np.ndarray
    bs: int
    shape: tuple[int, ...]

    def rows(self, values: np.ndarray) -> np.ndarray:
        """The owned cells' values, one row per cell (blocks of the cell side by side)."""
        blocks = np.asarray(values).reshape(-1, self.bs)[self.entries[: self.n_owned]]
        return blocks.reshape(self.n_owned, self.width)

    @property
    def width(self) -> int:
        """Values per cell."""
        return self.entries.shape[1] * self.bs

    def fill(self, rows: np.ndarray) -> np.ndarray:
        """The local array from one row per local cell (owned and ghost), as :meth:`rows`."""
        out = np.zeros(self.shape)
        n_cells, per_cell = self.entries.shape
        out.reshape(-1, self.bs)[self.entries] = rows.reshape(n_cells, per_cell, self.bs)
        return out


@dataclass(frozen=True)
class BodyDomain:
    """The mesh of one body and its relation to the scene mesh.

    Attributes:
        md: The scene's mesh data (parent mesh, tags, group names).
        mesh: The body's own mesh: the parent itself, or a cell submesh.
        entity_map: Submesh cell -> parent cell map (None when ``mesh`` is the parent).
        parent_cells: Parent indices of the body's cells (owned and ghost).
        facet_tags: The parent's facet tags transferred to ``mesh``.
    """

    md: MeshData
    mesh: object
    entity_map: object | None
    parent_cells: np.ndarray
    facet_tags: object

    @classmethod
    def create(cls, md: MeshData, region: str | None) -> BodyDomain:
        """The domain of the body on volume group ``region`` (None: the whole mesh)."""
        parent = md.mesh
        if region is None:
            imap = parent.topology.index_map(3)
            cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
            return cls(md, parent, None, cells, md.facet_tags)
        cells = md.cells(region)
        n_owned = parent.comm.allreduce(
            int(np.count_nonzero(cells < parent.topology.index_map(3).size_local)))
        if n_owned == 0:
            raise InputError("body.region", f"volume group {region!r} has no cells")
        sub, emap, vmap, _ = mesh.create_submesh(parent, 3, cells)
        tags = mesh.transfer_meshtags_to_submesh(md.facet_tags, sub, vmap, emap)
        # the parent cells in the submesh's cell order
        n_sub = sub.topology.index_map(3).size_local + sub.topology.index_map(3).num_ghosts
        parent_cells = emap.sub_topology_to_topology(np.arange(n_sub, dtype=np.int32),
                                                     inverse=False)
        return cls(md, sub, emap, np.asarray(parent_cells, dtype=np.int32), tags)

    @property
    def is_submesh(self) -> bool:
        """True when the body has a mesh of its own."""
        return self.entity_map is not None

    @property
    def n_owned_cells(self) -> int:
        """Number of cells of the body's mesh owned by this rank."""
        return self.mesh.topology.index_map(3).size_local

    @property
    def own_cells(self) -> np.ndarray:
        """Owned then ghost cells of the body's own mesh."""
        imap = self.mesh.topology.index_map(3)
        return np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)

    def cell_keys(self) -> np.ndarray:
        """Original (mesh-generator) index of the scene-mesh cell of every own cell.

        The same cell has the same key on any partition and number of ranks.
        """
        original = self.md.mesh.topology.original_cell_index
        return np.asarray(original, dtype=np.int64)[self.parent_cells]

    def layout(self, space: fem.FunctionSpace) -> CellLayout:
        """Layout of the values of a function on ``space`` (a space on :attr:`mesh`)."""
        dofmap = space.dofmap
        imap = dofmap.index_map
        bs = dofmap.index_map_bs
        return CellLayout(self.cell_keys(), self.n_owned_cells, dofmap.list, bs,
                          ((imap.size_local + imap.num_ghosts) * bs,))

    def point_layout(self, points_per_cell: int, width: int | None) -> CellLayout:
        """Layout of an array over the quadrature points of the owned cells, cell by cell.

        The point kernels run on owned cells only, so such arrays (``(points, width)``)
        have no ghost part.

        Args:
            points_per_cell: Quadrature points of a cell.
            width: Values per point (None: a 1-D array, one value per point).
        """
        n_cells = self.n_owned_cells
        entries = np.arange(n_cells * points_per_cell).reshape(n_cells, points_per_cell)
        shape = (n_cells * points_per_cell,) + (() if width is None else (width,))
        return CellLayout(self.cell_keys()[:n_cells], n_cells, entries, width or 1, shape)

    @property
    def entity_maps(self) -> list:
        """Entity maps for forms that mix this body's functions with the parent mesh."""
        return [] if self.entity_map is None else [self.entity_map]

    def facets(self, region: str) -> np.ndarray:
        """Facets of the surface group ``region`` on the body's own mesh.

        Raises:
            InputError: No such group, or the group has no facet on this body.
        """
        ids = self.md.facet_tag_ids(region)
        self.mesh.topology.create_connectivity(2, 3)
        found = np.unique(np.concatenate([self.facet_tags.find(t) for t in ids]))
        n_all = self.mesh.comm.allreduce(int(found.size), op=MPI.SUM)
        if n_all == 0:
            raise InputError("region", f"surface group {region!r} has no facet on this body")
        return found.astype(np.int32)

    def dx(self, *degrees: int) -> list[ufl.Measure]:
        """Parent-mesh cell measures over the body's cells, one per quadrature degree.

        Each measure has its own subdomain id over the same cells, so FFCx generates one
        kernel per measure: integrals of different degrees must not share a kernel in
        FFCx 0.11 (see ``FabricBody``). The measures share one subdomain list, so they
        can appear in one form.
        """
        # owned cells only: a ghost cell is assembled by its owner
        cells = np.sort(self.parent_cells[: self.n_owned_cells])
        data = [(i + 1, cells) for i in range(len(degrees))]
        return [ufl.Measure("dx", domain=self.md.mesh, subdomain_data=data, subdomain_id=i + 1,
                            metadata={"quadrature_degree": q})
                for i, q in enumerate(degrees)]

    def own_dx(self, degree: int) -> ufl.Measure:
        """Cell measure on the body's own mesh (post-processing)."""
        return ufl.Measure("dx", domain=self.mesh, metadata={"quadrature_degree": degree})

    def ds(self, region: str, **metadata) -> ufl.Measure:
        """Parent-mesh exterior facet measure of the surface group ``region``."""
        ids = self.md.facet_tag_ids(region)
        return ufl.Measure("ds", domain=self.md.mesh, subdomain_data=self.md.facet_tags,
                           subdomain_id=ids if len(ids) > 1 else ids[0],
                           metadata=metadata or None)

    def form(self, ufl_form) -> fem.Form:
        """Compile a form that uses this body's functions on the parent mesh."""
        return fem.form(ufl_form, entity_maps=self.entity_maps or None)
