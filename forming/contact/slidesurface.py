"""The surfaces of finite sliding: replicated facets, pairing search, nodal normals.

Each rank holds the whole surface (:class:`Surface`: its nodes' reference coordinates and
global indices, its facets as rows of four node indices, counter-clockwise seen from
outside the body, and their one-rings), and gathers its current displacements before
every evaluation (24 bytes per surface node and rank). See docs/theory.md, section 11.
"""

from __future__ import annotations

import numba
import numpy as np
from dolfinx import mesh
from mpi4py import MPI

from forming.contact.slidekernels import FADE, normal_gap, project_quad
from forming.layout import Layout

INSIDE = 1.0 + FADE  # a projection within this of the facet's +/-1 bounds is on it
_QUAD = [0, 1, 3, 2]  # DOLFINx's tensor-product facet vertices, counter-clockwise


@numba.njit(cache=True)
def search_all(xs, facets, xm, out_f, out_xi):
    """Pair every point with its nearest facet (all facets; centroid-pruned)."""
    nf = facets.shape[0]
    cen = np.zeros((nf, 3))
    rad = np.zeros(nf)
    for f in range(nf):
        for a in range(4):
            cen[f] += 0.25 * xm[facets[f, a]]
        for a in range(4):
            rad[f] = max(rad[f], np.sqrt(np.sum((xm[facets[f, a]] - cen[f]) ** 2)))
    for i in range(xs.shape[0]):
        order = np.argsort(np.sqrt(np.sum((cen - xs[i]) ** 2, axis=1)) - rad)
        best_d = np.inf
        out_f[i] = order[0]
        for f in order:
            if np.sqrt(np.sum((cen[f] - xs[i]) ** 2)) - rad[f] > best_d:
                break
            X = xm[facets[f]]
            xi, eta = project_quad(xs[i], X, 0.0, 0.0)
            cx, ce = max(-1.0, min(1.0, xi)), max(-1.0, min(1.0, eta))
            _n, p, _g = normal_gap(xs[i], X, cx, ce)
            d = np.sqrt(np.sum((xs[i] - p) ** 2))
            if d < best_d:
                best_d = d
                out_f[i] = f
                out_xi[i, 0] = xi
                out_xi[i, 1] = eta


def node_normals(xm: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """Unit normals at the master nodes: the mean of the adjacent facets' area vectors."""
    p = xm[facets]
    area = 0.5 * np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])  # a quad's area vector
    acc = np.zeros_like(xm)
    for a in range(4):
        np.add.at(acc, facets[:, a], area)
    return acc / np.linalg.norm(acc, axis=1)[:, None]


def one_rings(facets: np.ndarray, n_nodes: int) -> list[np.ndarray]:
    """Facets sharing a node with each facet, the facet itself first."""
    by_node = [[] for _ in range(n_nodes)]
    for f, nodes in enumerate(facets):
        for v in nodes:
            by_node[v].append(f)
    rings = []
    for f, nodes in enumerate(facets):
        others = sorted({g for v in nodes for g in by_node[v]} - {f})
        rings.append(np.array([f, *others], dtype=np.int64))
    return rings


def open_sides(facets: np.ndarray) -> np.ndarray:
    """1.0 where a facet's side (xi = -1, xi = 1, eta = -1, eta = 1) has no neighbour."""
    sides = ((0, 3), (1, 2), (0, 1), (2, 3))  # node pairs of each side
    count: dict[tuple[int, int], int] = {}
    for row in facets:
        for a, b in sides:
            key = tuple(sorted((int(row[a]), int(row[b]))))
            count[key] = count.get(key, 0) + 1
    return np.array([[float(count[tuple(sorted((int(row[a]), int(row[b]))))] == 1)
                      for a, b in sides] for row in facets]).reshape(-1, 4)


@numba.njit(cache=True)
def _distance_to(x, X, a, b):
    """Distance from x to the point (a, b) of the bilinear facet X (4, 3)."""
    N0 = 0.25 * (1 - a) * (1 - b)
    N1 = 0.25 * (1 + a) * (1 - b)
    N2 = 0.25 * (1 + a) * (1 + b)
    N3 = 0.25 * (1 - a) * (1 + b)
    d2 = 0.0
    for j in range(3):
        p = N0 * X[0, j] + N1 * X[1, j] + N2 * X[2, j] + N3 * X[3, j]
        d2 += (x[j] - p) ** 2
    return np.sqrt(d2)


@numba.njit(cache=True)
def ring_step(x, f0, xi0, eta0, facets, xm, rings):
    """The facet of ``f0``'s one-ring whose (clamped) closest point to x is nearest.

    Returns it and x's unclamped coordinates on it; projections start from (xi0, eta0)
    on ``f0`` and from the centre elsewhere.
    """
    best, best_d, bxi, beta = f0, np.inf, 0.0, 0.0
    for f in rings[f0]:
        if f < 0:
            break
        X = xm[facets[f]]
        a, b = project_quad(x, X, xi0 if f == f0 else 0.0, eta0 if f == f0 else 0.0)
        d = _distance_to(x, X, max(-1.0, min(1.0, a)), max(-1.0, min(1.0, b)))
        if d < best_d - 1e-12:
            best, best_d, bxi, beta = f, d, a, b
    return best, bxi, beta


def padded(rings: list[np.ndarray]) -> np.ndarray:
    """One-rings as rows of one array, padded with -1 (for the compiled walks)."""
    out = np.full((len(rings), max(len(r) for r in rings)), -1, dtype=np.int64)
    for f, r in enumerate(rings):
        out[f, :len(r)] = r
    return out


class Surface:
    """A surface's facets on every rank, with their nodes' global indices (replicated)."""

    def __init__(self, body, facets_local: np.ndarray, layout: Layout, name: str):
        msh, V, comm = body.mesh, body.V, body.mesh.comm
        self.comm = comm
        tdim = 3
        msh.topology.create_connectivity(2, tdim)
        geo = mesh.entities_to_geometry(msh, 2, facets_local.astype(np.int32))[:, _QUAD]
        # geometry node -> dof block (P1: the cell's geometry nodes and dofs align)
        g2d = np.empty(msh.geometry.x.shape[0], dtype=np.int64)
        gdofs = msh.geometry.dofmaps[0]
        g2d[gdofs.reshape(-1)] = V.dofmap.list.reshape(-1)
        blocks = g2d[geo]
        # orient each facet's normal out of the master body (away from its cell)
        f2c = msh.topology.connectivity(2, tdim)
        x = msh.geometry.x
        for k, f in enumerate(facets_local):
            cell = f2c.links(f)[0]
            centre = x[gdofs[cell]].mean(axis=0)
            P = x[geo[k]]
            n = np.cross(P[1] - P[0], P[3] - P[0])
            if n @ (P.mean(axis=0) - centre) < 0:
                blocks[k] = blocks[k][[0, 3, 2, 1]]
        imap = V.dofmap.index_map
        keys = imap.local_to_global(blocks.reshape(-1)).reshape(-1, 4)
        glob = layout.index(name).reshape(-1, 3)
        fixed = layout.prescribed(name).reshape(-1, 3)
        X0 = V.tabulate_dof_coordinates()
        local_nodes = np.unique(blocks)
        node_rows = (imap.local_to_global(local_nodes), X0[local_nodes],
                     glob[local_nodes], fixed[local_nodes])
        all_keys = np.concatenate(comm.allgather(keys))
        all_nodes = comm.allgather(node_rows)
        node_keys = np.concatenate([r[0] for r in all_nodes])
        uniq, first = np.unique(node_keys, return_index=True)
        self.keys = uniq
        self.X0 = np.concatenate([r[1] for r in all_nodes])[first]
        index = np.concatenate([r[2] for r in all_nodes])[first]
        prescribed = np.concatenate([r[3] for r in all_nodes])[first]
        self.index = np.where(prescribed, -1, index)  # -1: PETSc skips the entry
        # facets as rows of node positions, each once
        _u, once = np.unique(np.sort(all_keys, axis=1), axis=0, return_index=True)
        self.facets = np.searchsorted(uniq, all_keys[np.sort(once)])
        self.rings = one_rings(self.facets, len(uniq))
        self.rings_padded = padded(self.rings)
        self.open_sides = open_sides(self.facets)
        # this rank's owned master nodes, and where their values go in the gathered table
        owned = local_nodes[local_nodes < imap.size_local]
        self._owned = owned
        counts = comm.allgather(len(owned))
        self._counts = np.array(counts) * 3
        self._displs = np.concatenate([[0], np.cumsum(self._counts)[:-1]])
        order = np.concatenate(comm.allgather(imap.local_to_global(owned)))
        self._perm = np.searchsorted(uniq, order)
        self._u = body.u

    def positions(self) -> np.ndarray:
        """Current coordinates of every master node (one gather)."""
        return self.X0 + self.gather(self._u.x.array)

    def gather(self, values: np.ndarray) -> np.ndarray:
        """Every master node's values (n, 3) from a body array of 3 per node (one gather).

        Args:
            values: An array over the master body's dofs (displacements, velocities).
        """
        mine = np.ascontiguousarray(values.reshape(-1, 3)[self._owned]).reshape(-1)
        out = np.empty(int(self._counts.sum()))
        self.comm.Allgatherv(mine, [out, self._counts, self._displs, MPI.DOUBLE])
        x = np.zeros_like(self.X0)
        x[self._perm] = out.reshape(-1, 3)
        return x
