"""How the cells of a mesh are shared among the ranks: by graph or in angular wedges.

``graph`` (the default) is DOLFINx's graph partitioner: equal cell counts, the smallest
cut. It knows nothing of where the work is. In a quarter model formed by a punch at the
symmetry axis (the hemisphere, the square punch) the elements that crush and rotate,
whose stress updates cost more, lie around that axis, and a graph partition puts most
of them on one rank: every explicit increment, and every Newton iteration's kernel,
waits for that rank (docs/performance.md, ``timing.element_loops_imbalance``).

``wedge`` cuts the plan into sectors about a vertical axis (the scene's symmetry axis,
x = y = 0 by default), equal in cell count: each rank holds a sector of the region
around the axis, the same share of it where the scene is symmetric about the quarter's
diagonal, and a whole column of every body through the thickness (skins and core with
their contact partners on the same rank). The price is a longer cut: about a radius of
cells per boundary against the graph partition's shortest cut. Meant for a few ranks;
with many, the sectors grow thin.

Both ghost the cells across a shared facet (interface integrals, docs in
:mod:`forming.compat`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import dolfinx
import numpy as np

from forming import compat  # noqa: F401  (the package's compat checks)
from forming.errors import InputError

Partition = Literal["graph", "wedge"]
PARTITIONS = ("graph", "wedge")


def check(partition: str) -> None:
    """Raise an :class:`InputError` naming ``partition`` if it is not a known partition."""
    if partition not in PARTITIONS:
        raise InputError("partition", f"must be one of {list(PARTITIONS)}, got {partition!r}")


def mesh_partition(setting: str) -> Partition:
    """A case's ``partition`` setting as a mesh's.

    ``auto`` that the case runner did not resolve (:func:`forming.case.resolve_partition`;
    a build called directly) is the graph partition.
    """
    if setting == "auto":
        return "graph"
    check(setting)
    return setting  # type: ignore[return-value]


def wedge_owners(centroids: np.ndarray, nparts: int,
                 centre: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """The rank of each cell: sectors about the vertical axis through ``centre``.

    Args:
        centroids: Cell centres, (n, 2 or 3) [mm].
        nparts: Number of sectors (ranks).
        centre: Point of the axis in plan.

    Returns:
        (n,) int32 sector of each cell; cells are ordered by their angle about the axis
        (ties by distance from it) and split into ``nparts`` runs of equal length.
    """
    n = len(centroids)
    if n == 0:
        return np.zeros(0, dtype=np.int32)
    dx = centroids[:, 0] - centre[0]
    dy = centroids[:, 1] - centre[1]
    order = np.lexsort((np.hypot(dx, dy), np.arctan2(dy, dx)))
    owners = np.empty(n, dtype=np.int32)
    owners[order] = (np.arange(n, dtype=np.int64) * nparts // n).astype(np.int32)
    return owners


def _wedge_graph_partitioner(centroids: np.ndarray, centre: tuple[float, float]) -> Callable:
    """A DOLFINx graph partitioner placing the cells in sectors (:func:`wedge_owners`).

    ``centroids`` are the centres of this rank's input cells, in their input order (the
    order of the dual graph's nodes). The ghosts are the other owners of each cell's
    neighbours across a facet, which the dual graph lists.
    """

    def partition(comm, nparts: int, graph, ghosting: bool):
        n = graph.num_nodes
        if len(centroids) != n:
            raise RuntimeError(f"wedge partition: {len(centroids)} cell centres for {n} "
                               f"cells on rank {comm.rank}")
        everyone = np.concatenate(comm.allgather(np.asarray(centroids, dtype=float)
                                                 .reshape(-1, 3)))
        owners_all = wedge_owners(everyone, nparts, centre)
        start = sum(comm.allgather(n)[:comm.rank])
        owners = owners_all[start:start + n]
        if not ghosting:
            return dolfinx.graph.adjacencylist(owners)._cpp_object
        offsets, links = np.asarray(graph.offsets), np.asarray(graph.array)
        cell = np.repeat(np.arange(n), np.diff(offsets))
        rank = owners_all[links]
        away = rank != owners[cell]
        ghosts = np.unique(cell[away].astype(np.int64) * nparts + rank[away])
        g_cell, g_rank = ghosts // nparts, (ghosts % nparts).astype(np.int32)
        counts = 1 + np.bincount(g_cell, minlength=n)
        dest_off = np.zeros(n + 1, dtype=np.int32)
        np.cumsum(counts, out=dest_off[1:])
        dest = np.empty(dest_off[-1], dtype=np.int32)
        dest[dest_off[:-1]] = owners
        # ghost ranks after the owner, in the order np.unique left them (by cell)
        slot = np.arange(len(g_cell)) - np.searchsorted(g_cell, g_cell) + 1
        dest[dest_off[g_cell] + slot] = g_rank
        return dolfinx.graph.adjacencylist(dest, dest_off)._cpp_object

    return partition


def cell_partitioner(partition: Partition, centroids: np.ndarray | None = None,
                     centre: tuple[float, float] = (0.0, 0.0)):
    """The DOLFINx cell partitioner of ``partition``, ghosting cells across shared facets.

    Args:
        partition: ``"graph"`` or ``"wedge"``.
        centroids: ``wedge``: centres of this rank's input cells in input order.
        centre: ``wedge``: the axis point in plan.
    """
    check(partition)
    mode = dolfinx.mesh.GhostMode.shared_facet
    if partition == "graph":
        return dolfinx.mesh.create_cell_partitioner(mode, 2)
    cen = np.zeros((0, 3)) if centroids is None else np.asarray(centroids, dtype=float)
    return dolfinx.mesh.create_cell_partitioner(_wedge_graph_partitioner(cen, centre), mode, 2)
