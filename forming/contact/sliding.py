"""Finite-sliding contact between two deformable bodies: slave nodes on master facets.

The slave side's nodes (a skin's face) meet the master side's facets (a core's face,
bilinear quadrilaterals) in the current configuration, so the two surfaces may be meshed
independently and slide any distance. Each rank holds the whole master surface
(replicated: its reference coordinates, and its current displacements gathered before
every evaluation, 24 bytes per surface node and rank); slave nodes are the rank's owned
ones. See docs/theory.md, section 11.

* **Pairing**: at the first evaluation of every load step each slave node is paired with
  the facet whose closest point is nearest (a search over all facets); within the
  Newton iterations it moves to the nearest facet of its pair's one-ring. A node whose
  closest point lies beyond the master surface's edge (by more than 2% of a facet) is
  not in contact.
* **Normal contact**: augmented Lagrangian at the slave nodes, ``p = <lambda - eps g>``,
  the multipliers updated like the tool contacts' (``violation``, ``augment``). The
  normal is the master's nodal normals (area-weighted facet normals, taken at the start
  of each load step and held within it) interpolated at the closest point: continuous
  from facet to facet, where the facets' own normals jump (a slave node on a facet
  edge then flipped between the two facets at every Newton iteration).
* **Friction**: Coulomb with the elastic-slip stick law (stiffness ``mu p / s_el``). The
  slip of a step is the slave node's motion relative to the master's *material* point it
  touched at the last converged step (its facet and coordinates are history), so it is
  right after the node has moved onto another facet.
* **Assembly**: outside the forms: each pair's residual on its 27 dofs (slave node, facet,
  history facet) and its Jacobian by central differences (slidekernels.py) are added to
  the solver's vector and matrix by global index (:class:`~forming.layout.Layout`);
  prescribed rows and columns are skipped.
"""

from __future__ import annotations

import numba
import numpy as np
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI
from petsc4py import PETSc

from forming.contact.slidekernels import normal_gap, pair_jacobian, pair_residual, project_quad
from forming.contact.terms import surface_edge_min
from forming.history import ForceSampler
from forming.layout import Layout
from forming.vectors import assembled

_INSIDE = 1.02  # a projection within this of the facet's +/-1 bounds counts as on it
_QUAD = [0, 1, 3, 2]  # DOLFINx's tensor-product facet vertices, counter-clockwise


@numba.njit(cache=True)
def _choose(x, cands, facets, xm, xi0, eta0):
    """The candidate facet nearest to x; its coordinates and whether x projects onto it."""
    best, best_d, bxi, beta, inside = -1, np.inf, 0.0, 0.0, False
    for f in cands:
        X = xm[facets[f]]
        xi, eta = project_quad(x, X, xi0 if f == cands[0] else 0.0,
                               eta0 if f == cands[0] else 0.0)
        cx, ce = max(-1.0, min(1.0, xi)), max(-1.0, min(1.0, eta))
        _n, p, _g = normal_gap(x, X, cx, ce)
        d = np.sqrt(np.sum((x - p) ** 2))
        if d < best_d - 1e-12:
            best, best_d, bxi, beta = f, d, xi, eta
            inside = abs(xi) <= _INSIDE and abs(eta) <= _INSIDE
    return best, bxi, beta, inside


@numba.njit(cache=True)
def _search_all(xs, facets, xm, out_f, out_xi):
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


def _node_normals(xm: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """Unit normals at the master nodes: the mean of the adjacent facets' area vectors."""
    p = xm[facets]
    area = 0.5 * np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])  # a quad's area vector
    acc = np.zeros_like(xm)
    for a in range(4):
        np.add.at(acc, facets[:, a], area)
    return acc / np.linalg.norm(acc, axis=1)[:, None]


def _one_rings(facets: np.ndarray, n_nodes: int) -> list[np.ndarray]:
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


class _MasterSurface:
    """The master facets of every rank, with their nodes' global indices (replicated)."""

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
        self.rings = _one_rings(self.facets, len(uniq))
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
        mine = np.ascontiguousarray(self._u.x.array.reshape(-1, 3)[self._owned]).reshape(-1)
        out = np.empty(int(self._counts.sum()))
        self.comm.Allgatherv(mine, [out, self._counts, self._displs, MPI.DOUBLE])
        x = self.X0.copy()
        x[self._perm] += out.reshape(-1, 3)
        return x


class SlidingTerm:
    """Finite-sliding frictional contact of a slave region on a master region.

    Args:
        spec: The scene's sliding interface.
        master: The master body (its facets carry the normal).
        slave: The slave body (its nodes are constrained).
        layout: The solver's global dof layout.
        thickness: Smallest extent of the two bodies [mm] (caps the default tolerance).
    """

    assembled_outside_forms = True

    def __init__(self, spec, master, slave, layout: Layout, thickness: float):
        self.spec = spec
        self.name = spec.name
        self.bodies = (spec.master, spec.slave)
        self.comm = slave.mesh.comm
        m_facets = master.domain.facets(spec.master_region)
        s_facets = slave.domain.facets(spec.slave_region)
        h = min(surface_edge_min(master.mesh, m_facets), surface_edge_min(slave.mesh, s_facets))
        self.edge = h
        self.tolerance = spec.tolerance or 0.01 * min(h, thickness)
        self.penalty = spec.penalty or 10.0 * master.contact_stiffness() / h
        self.friction = spec.friction
        self.elastic_slip = 0.005 * h
        self.master = _MasterSurface(master, m_facets, layout, spec.master)
        self.slave = slave
        V = slave.V
        nodes = fem.locate_dofs_topological(V, 2, s_facets)
        self.nodes = nodes[nodes < V.dofmap.index_map.size_local].astype(np.int64)
        w = ufl.TestFunction(V)
        ds = slave.domain.ds(spec.slave_region, quadrature_rule="vertex", quadrature_degree=1)
        area = fem.Function(V)
        assembled(slave.domain.form(ufl.dot(ufl.as_vector([1.0, 1.0, 1.0]), w) * ds), area)
        self.area = area.x.array.reshape(-1, 3)[self.nodes, 0].copy()
        glob = layout.index(spec.slave).reshape(-1, 3)
        fixed = layout.prescribed(spec.slave).reshape(-1, 3)
        self.s_index = np.where(fixed[self.nodes], -1, glob[self.nodes])
        self.X0 = V.tabulate_dof_coordinates()[self.nodes]
        n = len(self.nodes)
        # pairing (this step) and history (last converged step), per owned slave node
        self.facet = np.zeros(n, dtype=np.int64)
        self.xi = np.zeros((n, 2))
        self.inside = np.zeros(n, dtype=bool)
        self._repair = True
        self.lam_n = np.zeros(n)
        self.p_new = np.zeros(n)
        self.gap = np.full(n, np.inf)
        self.shear = np.zeros((n, 3))
        self.force = np.zeros((n, 3))  # force on each slave node [N]
        self.hist = np.full(n, -1, dtype=np.int64)  # history facet (-1: none)
        self.hist_xi = np.zeros((n, 2))
        self.rel = np.zeros((n, 3))  # slave minus the history material point, at commit
        self.lam_t = np.zeros((n, 3))  # converged shear traction
        # the master point each slave node starts on (its total slip is measured from it)
        self._start = np.zeros(n, dtype=np.int64)
        self._start_xi = np.zeros((n, 2))
        _search_all(np.ascontiguousarray(self.X0), self.master.facets, self.master.X0,
                    self._start, self._start_xi)

    # -- what the model asks of every constraint -------------------------------------------
    def residuals(self, tests: dict) -> dict:
        """None in the forms: the term is assembled by :meth:`add_residual`."""
        return {}

    def stiffness_estimate(self, tests: dict) -> dict:
        """None (the explicit solver does not take finite sliding yet)."""
        return {}

    def set_load(self, t: float) -> None:
        """A new load step: pair the slave nodes with facets again at the next evaluation."""
        self._repair = True

    def track(self) -> None:
        """Nothing here: the pairing follows inside :meth:`add_residual`."""

    # -- evaluation ------------------------------------------------------------------------
    def _slave_positions(self) -> np.ndarray:
        return self.X0 + self.slave.u.x.array.reshape(-1, 3)[self.nodes]

    def _pair(self, xs: np.ndarray, xm: np.ndarray) -> None:
        facets = self.master.facets
        if self._repair:
            _search_all(xs, facets, xm, self.facet, self.xi)
            self.node_normal = _node_normals(xm, facets)
            self._repair = False
        for i in range(len(xs)):
            f, xi, eta, inside = _choose(xs[i], self.master.rings[self.facet[i]], facets, xm,
                                         self.xi[i, 0], self.xi[i, 1])
            self.facet[i], self.xi[i], self.inside[i] = f, (xi, eta), inside

    def _pairs(self):
        """Per active pair: its 27 dofs' positions and global indices, and its data."""
        xs = self._slave_positions()
        xm = self.master.positions()
        self._pair(xs, xm)
        facets, index = self.master.facets, self.master.index
        for i in np.flatnonzero(self.inside):
            f = self.facet[i]
            h = self.hist[i] if self.hist[i] >= 0 else f
            z = np.concatenate([xs[i], xm[facets[f]].reshape(-1), xm[facets[h]].reshape(-1)])
            idx = np.concatenate([self.s_index[i], index[facets[f]].reshape(-1),
                                  index[facets[h]].reshape(-1)]).astype(PETSc.IntType)
            yield i, z, idx

    def _args(self, i: int):
        nn = self.node_normal[self.master.facets[self.facet[i]]]
        return (nn, self.xi[i, 0], self.xi[i, 1], self.hist_xi[i, 0], self.hist_xi[i, 1],
                self.hist[i] >= 0, self.rel[i], self.lam_n[i], self.lam_t[i], self.penalty,
                self.friction, self.elastic_slip, self.area[i])

    def add_residual(self, b: PETSc.Vec) -> None:
        """Add the contact's residual to the solver's vector (global indices)."""
        r = np.zeros(27)
        self.gap[:] = np.inf
        self.p_new[:] = 0.0
        self.shear[:] = 0.0
        self.force[:] = 0.0
        for i, z, idx in self._pairs():
            g, p, shear, _closed, _slip = pair_residual(z, *self._args(i), r)
            self.gap[i], self.p_new[i], self.shear[i] = g, p, shear
            self.force[i] = -r[:3]
            keep = idx >= 0  # (a vector does not skip negative indices as a matrix does)
            b.setValues(idx[keep], r[keep], addv=PETSc.InsertMode.ADD_VALUES)
        b.assemblyBegin()
        b.assemblyEnd()

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """Add the contact's Jacobian to the solver's matrix (global indices)."""
        K = np.zeros((27, 27))
        for i, z, idx in self._pairs():
            pair_jacobian(z, *self._args(i), K)
            A.setValues(idx, idx, K, addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()

    # -- augmented Lagrangian and history --------------------------------------------------
    def _max(self, values: np.ndarray) -> float:
        return self.comm.allreduce(float(values.max()) if values.size else 0.0, op=MPI.MAX)

    def penetration(self) -> float:
        """Largest penetration of a slave node [mm] (of the last evaluation)."""
        g = self.gap[np.isfinite(self.gap)]
        return max(self._max(-g), 0.0)

    def violation(self) -> float:
        """Largest change of a normal multiplier over the penalty [mm]."""
        return self._max(np.abs(self.p_new - self.lam_n)) / self.penalty

    def augment(self) -> None:
        """Uzawa update of the normal multipliers."""
        self.lam_n[:] = self.p_new

    def commit(self) -> None:
        """Accept the step: the touched master points and the shear become history."""
        xs = self._slave_positions()
        xm = self.master.positions()
        touching = self.inside & (self.p_new > 0.0)
        self.hist[:] = np.where(touching, self.facet, -1)
        self.hist_xi[:] = self.xi
        self.lam_t[:] = np.where(touching[:, None], self.shear, 0.0)
        for i in np.flatnonzero(touching):
            X = xm[self.master.facets[self.facet[i]]]
            _n, p, _g = normal_gap(xs[i], X, self.xi[i, 0], self.xi[i, 1])
            self.rel[i] = xs[i] - p

    def _full(self, values: np.ndarray) -> np.ndarray:
        """Node values (n, 3) as an array over the slave body's dofs (NaN elsewhere)."""
        out = np.full(self.slave.u.x.array.size, np.nan)
        out.reshape(-1, 3)[self.nodes] = values
        return out

    def snapshot(self) -> tuple:
        """Multipliers, converged shear and friction history over the slave's dofs.

        The history's master point is stored by its reference coordinates, so that a
        checkpoint holds nothing that depends on the partition.
        """
        ref = np.full((len(self.nodes), 3), np.nan)
        for i in np.flatnonzero(self.hist >= 0):
            X = self.master.X0[self.master.facets[self.hist[i]]]
            ref[i] = normal_gap(X[0], X, self.hist_xi[i, 0], self.hist_xi[i, 1])[1]
        lam = np.zeros((len(self.nodes), 3))
        lam[:, 0] = self.lam_n
        return tuple(self._full(a) for a in (lam, ref, self.rel, self.lam_t))

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot (and pair again at the next evaluation)."""
        lam, ref, rel, lam_t = (a.reshape(-1, 3)[self.nodes] for a in snap)
        self.lam_n[:] = lam[:, 0]
        self.rel[:] = rel
        self.lam_t[:] = lam_t
        has = np.isfinite(ref[:, 0])
        self.hist[:] = -1
        if has.any():  # find the material points again in the reference configuration
            f = np.zeros(int(has.sum()), dtype=np.int64)
            xi = np.zeros((int(has.sum()), 2))
            _search_all(np.ascontiguousarray(ref[has]), self.master.facets, self.master.X0,
                        f, xi)
            self.hist[has] = f
            self.hist_xi[has] = xi
        self._repair = True

    def snapshot_layout(self) -> tuple:
        """Every array lies over the slave body's dofs."""
        return (self.slave.domain.layout(self.slave.V),) * 4

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """Force of the master on the slave [N] (x, y, z), normal force, penetration [mm]."""
        f = self.comm.allreduce(self.force.sum(axis=0), op=MPI.SUM)
        fn = self.comm.allreduce(float(self.area @ self.p_new), op=MPI.SUM)
        return {f"sliding_{self.name}_{axis}_N": float(f[k]) for k, axis in enumerate("xyz")
                } | {f"sliding_{self.name}_normal_N": fn,
                     f"sliding_{self.name}_penetration_mm": self.penetration()}

    def max_slip(self) -> float:
        """Largest distance of a slave node from the master point it started on [mm]."""
        xs = self._slave_positions()
        xm = self.master.positions()
        worst = 0.0
        for i in range(len(xs)):
            X = xm[self.master.facets[self._start[i]]]
            p = normal_gap(xs[i], X, self._start_xi[i, 0], self._start_xi[i, 1])[1]
            worst = max(worst, float(np.linalg.norm(xs[i] - p)))
        return self.comm.allreduce(worst, op=MPI.MAX)

    def warnings(self) -> list[str]:
        """Nothing to warn about: the pairing follows any slip."""
        return []
