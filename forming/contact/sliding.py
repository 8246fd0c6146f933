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
  closest point lies beyond the master surface's edge is let go gradually: its force
  fades to zero over 10% of a facet (a cliff there made Newton cycle as an edge node
  stepped on and off the surface).
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

import time

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from forming.contact.slidebatch import pair_all, residual_all
from forming.contact.slidekernels import normal_gap, pair_jacobian, pair_residual, shape
from forming.contact.slidesurface import INSIDE, Surface, node_normals, search_all
from forming.contact.terms import surface_edge_min
from forming.contact.tributary import AreaTransfer, bilinear_points
from forming.history import ForceSampler
from forming.layout import Layout
from forming.vectors import assembled


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
        self.master = Surface(master, m_facets, layout, spec.master)
        self._master_body = master
        self.slave = slave
        V = slave.V
        nodes = fem.locate_dofs_topological(V, 2, s_facets)
        self.nodes = nodes[nodes < V.dofmap.index_map.size_local].astype(np.int64)
        self.spreading: AreaTransfer | None = None
        if spec.transfer == "area":
            surface = Surface(slave, s_facets, layout, spec.slave)
            keys = V.dofmap.index_map.local_to_global(self.nodes.astype(np.int32))
            self.spreading = AreaTransfer(surface, np.searchsorted(surface.keys, keys),
                                          self.master.facets, self.master.rings_padded)
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
        self._search_on_load = True
        self.seconds = 0.0  # wall time of the search and the pairs' evaluations [s]
        self.lam_n = np.zeros(n)
        self.p_new = np.zeros(n)
        self.gap = np.full(n, np.inf)
        self.shear = np.zeros((n, 3))
        self.force = np.zeros((n, 3))  # force on each slave node [N]
        self.spring = np.zeros((n, 3))  # stabilising force on each slave node [N]
        self.kappa = spec.stabilisation * self.penalty
        # the master point each slave node starts on (its total slip is measured from it)
        self._start = np.zeros(n, dtype=np.int64)
        self._start_xi = np.zeros((n, 2))
        search_all(np.ascontiguousarray(self.X0), self.master.facets, self.master.X0,
                   self._start, self._start_xi)
        # the master material point each node was at when the step began (history facet,
        # its coordinates, slave minus that point), and whether it touched (friction)
        self.hist = self._start.copy()
        self.hist_xi = self._start_xi.copy()
        self.rel = self.X0 - self._point(self.master.X0, self._start, self._start_xi)
        self.touched = np.zeros(n, dtype=bool)
        self.lam_t = np.zeros((n, 3))  # converged shear traction

    def _point(self, xm: np.ndarray, facet: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """The master points at coordinates ``xi`` (n, 2) of ``facet`` (n,) [mm] (n, 3)."""
        return bilinear_points(xm[self.master.facets[facet]], xi)

    # -- what the model asks of every constraint -------------------------------------------
    def residuals(self, tests: dict) -> dict:
        """None in the forms: the term is assembled by :meth:`add_residual`."""
        return {}

    def stiffness_estimate(self, tests: dict) -> dict:
        """Twice the penalty on each side's surface nodes (the coupling rows add as much)."""
        ones = ufl.as_vector([1.0, 1.0, 1.0])
        return {name: 2.0 * self.penalty * ufl.dot(ones, tests[name]) * body.domain.ds(region)
                for name, body, region in ((self.spec.master, self._master_body,
                                            self.spec.master_region),
                                           (self.spec.slave, self.slave,
                                            self.spec.slave_region))}

    def set_load(self, t: float) -> None:
        """A new load step: pair the slave nodes again at the next evaluation.

        Unless :meth:`search_on_load` turned that off.
        """
        if self._search_on_load:
            self._repair = True

    def search_on_load(self, on: bool) -> None:
        """Whether every new load parameter starts with a full search.

        On for the implicit solver's load steps; off for the explicit solver, whose output
        intervals call :meth:`repair` and whose increments walk the one-rings.
        """
        self._search_on_load = on

    def repair(self) -> None:
        """Pair every slave node again (full search) at the next evaluation."""
        self._repair = True

    def track(self) -> None:
        """Nothing here: the pairing follows inside :meth:`add_residual`."""

    # -- evaluation ------------------------------------------------------------------------
    def _slave_positions(self) -> np.ndarray:
        return self.X0 + self.slave.u.x.array.reshape(-1, 3)[self.nodes]

    def _pair(self, xs: np.ndarray, xm: np.ndarray) -> None:
        facets = self.master.facets
        repaired = self._repair
        if repaired:
            search_all(xs, facets, xm, self.facet, self.xi)
            self.node_normal = node_normals(xm, facets)
            self._repair = False
        pair_all(xs, xm, facets, self.master.rings_padded, self.facet, self.xi, self.inside,
                 INSIDE)
        if self.spreading is not None:
            if repaired:
                self.spreading.repair(xs, xm, self.facet)
            else:
                self.spreading.follow(xs, xm)

    def _pairs(self):
        """Per active pair: its 27 dofs' positions and global indices, and its data."""
        xs = self._slave_positions()
        xm = self.master.positions()
        self._pair(xs, xm)
        self._xm = xm
        facets, index = self.master.facets, self.master.index
        for i in np.flatnonzero(self.inside):
            f = self.facet[i]
            h = self.hist[i]
            z = np.concatenate([xs[i], xm[facets[f]].reshape(-1), xm[facets[h]].reshape(-1)])
            idx = np.concatenate([self.s_index[i], index[facets[f]].reshape(-1),
                                  index[facets[h]].reshape(-1)]).astype(PETSc.IntType)
            yield i, z, idx

    def _args(self, i: int):
        nn = self.node_normal[self.master.facets[self.facet[i]]]
        return (nn, self.xi[i, 0], self.xi[i, 1], self.hist_xi[i, 0], self.hist_xi[i, 1],
                self.touched[i], self.rel[i], self.lam_n[i], self.lam_t[i], self.penalty,
                self.friction, self.elastic_slip, self.area[i],
                self.master.open_sides[self.facet[i]], self.kappa)

    def add_residual(self, b: PETSc.Vec) -> None:
        """Add the contact's residual to the solver's vector (global indices).

        Every pair in one compiled call (:func:`~forming.contact.slidebatch.residual_all`).
        """
        t0 = time.perf_counter()
        xs = self._slave_positions()
        xm = self.master.positions()
        self._pair(xs, xm)
        on = np.flatnonzero(self.inside)
        for a in (self.p_new, self.shear, self.force, self.spring):
            a[:] = 0.0
        self.gap[:] = np.inf
        sp = self.spreading
        if sp is None:
            size = 27 * len(on)
            ptr = np.zeros(1, dtype=np.int64)
            offsets, phi, pfacet, pxi = np.zeros((0, 3)), np.zeros(0), ptr, np.zeros((0, 2))
        else:
            points = np.diff(sp.ptr)[on]
            size = int(np.sum(15 + 12 * np.minimum(points, len(self.master.facets))))
            ptr, offsets, phi, pfacet, pxi = sp.ptr, sp.offsets, sp.phi, sp.facet, sp.xi
        rows = np.empty(size, dtype=np.int64)
        values = np.empty(size)
        n = residual_all(on, xs, xm, self.master.facets, self.master.index, self.s_index,
                         self.facet, self.xi, self.hist, self.hist_xi, self.touched, self.rel,
                         self.lam_n, self.lam_t, self.node_normal, self.master.open_sides,
                         self.area, self.penalty, self.friction, self.elastic_slip,
                         self.kappa, sp is not None, ptr, offsets, phi, pfacet, pxi,
                         rows, values, self.gap, self.p_new, self.shear, self.force,
                         self.spring)
        keep = rows[:n] >= 0  # (a vector does not skip negative indices as a matrix does)
        b.setValues(rows[:n][keep].astype(PETSc.IntType), values[:n][keep],
                    addv=PETSc.InsertMode.ADD_VALUES)
        self.seconds += time.perf_counter() - t0
        b.assemblyBegin()
        b.assemblyEnd()

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """Add the contact's Jacobian to the solver's matrix (global indices)."""
        t0 = time.perf_counter()
        K = np.zeros((27, 27))
        for i, z, idx in self._pairs():
            pair_jacobian(z, *self._args(i), K)
            if self.spreading is None:
                A.setValues(idx, idx, K, addv=PETSc.InsertMode.ADD_VALUES)
                continue
            A.setValues(idx[:3], idx, K[:3], addv=PETSc.InsertMode.ADD_VALUES)
            A.setValues(idx[15:], idx, K[15:], addv=PETSc.InsertMode.ADD_VALUES)
            mine, W, dW = self.spreading.weights(i, z[:3], self._xm, True)
            # the derivative of the contact force on the slave (3, 27): the residual's
            # slave rows without the stabilising spring's
            force = -K[:3] - self._spring_derivative(i)
            rows = self._rows(mine).reshape(-1, 12)
            t = self.force_of(i, z)
            for k in range(len(mine)):
                block = (W[k][:, None, None] * force[None]).reshape(12, 27)
                A.setValues(rows[k], idx, block, addv=PETSc.InsertMode.ADD_VALUES)
                # the weights move with the node (its first 3 dofs) and the facet's nodes
                cols = np.concatenate([idx[:3], rows[k]])
                A.setValues(rows[k], cols, (t[None, :, None] * dW[k][:, None, :]
                                            ).reshape(12, 15),
                            addv=PETSc.InsertMode.ADD_VALUES)
        self.seconds += time.perf_counter() - t0
        A.assemble()

    def _rows(self, facets: np.ndarray) -> np.ndarray:
        """Global indices of the nodes of master ``facets`` (-1: prescribed)."""
        return self.master.index[self.master.facets[facets]].reshape(-1).astype(PETSc.IntType)

    def force_of(self, i: int, z: np.ndarray) -> np.ndarray:
        """The contact force of the master on slave node ``i`` at the dofs ``z`` [N] (3,)."""
        r = np.zeros(27)
        spring = pair_residual(z, *self._args(i), r)[5]
        return -r[:3] - spring

    def _spring_derivative(self, i: int) -> np.ndarray:
        """Derivative (3, 27) of the stabilising spring's force on slave node ``i``."""
        S = np.zeros((3, 27))
        if self.kappa > 0.0:
            k = self.kappa * self.area[i]
            S[:, :3] = -k * np.eye(3)
            Nh = shape(self.hist_xi[i, 0], self.hist_xi[i, 1])
            for a in range(4):
                S[:, 15 + 3 * a:18 + 3 * a] = k * Nh[a] * np.eye(3)
        return S

    # -- augmented Lagrangian and history --------------------------------------------------
    def _max(self, values: np.ndarray) -> float:
        return self.comm.allreduce(float(values.max()) if values.size else 0.0, op=MPI.MAX)

    def penetration(self) -> float:
        """Largest penetration of a slave node [mm] (of the last evaluation)."""
        g = self.gap[np.isfinite(self.gap)]
        return max(self._max(-g), 0.0)

    def pressure_range(self) -> tuple[float, float]:
        """Smallest and largest nodal pressure of the slave nodes in contact [MPa]."""
        p = self.p_new[self.inside & (self.p_new > 0.0)]
        lo = self.comm.allreduce(float(p.min()) if p.size else np.inf, op=MPI.MIN)
        return lo, self._max(p)

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
        self.touched[:] = self.inside & (self.p_new > 0.0)
        self.hist[:] = self.facet
        self.hist_xi[:] = self.xi
        self.lam_t[:] = np.where(self.touched[:, None], self.shear, 0.0)
        self.rel[:] = xs - self._point(xm, self.facet, self.xi)

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
        ref = self._point(self.master.X0, self.hist, self.hist_xi)
        lam = np.zeros((len(self.nodes), 3))
        lam[:, 0] = self.lam_n
        lam[:, 1] = self.touched
        return tuple(self._full(a) for a in (lam, ref, self.rel, self.lam_t))

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot (and pair again at the next evaluation)."""
        lam, ref, rel, lam_t = (a.reshape(-1, 3)[self.nodes] for a in snap)
        self.lam_n[:] = lam[:, 0]
        self.touched[:] = lam[:, 1] > 0.5
        self.rel[:] = rel
        self.lam_t[:] = lam_t
        # find the material points again in the reference configuration
        search_all(np.ascontiguousarray(ref), self.master.facets, self.master.X0,
                   self.hist, self.hist_xi)
        self._repair = True

    def snapshot_layout(self) -> tuple:
        """Every array lies over the slave body's dofs."""
        return (self.slave.domain.layout(self.slave.V),) * 4

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """Force of the master on the slave [N] (x, y, z), normal force, penetration [mm]."""
        f = self.comm.allreduce(self.force.sum(axis=0), op=MPI.SUM)
        fn = self.comm.allreduce(float(self.area @ self.p_new), op=MPI.SUM)
        extra = {}
        if self.kappa > 0.0:
            spring = self.comm.allreduce(self.spring.sum(axis=0), op=MPI.SUM)
            extra = {f"sliding_{self.name}_stabilisation_N": float(np.linalg.norm(spring))}
        return {f"sliding_{self.name}_{axis}_N": float(f[k]) for k, axis in enumerate("xyz")
                } | {f"sliding_{self.name}_normal_N": fn,
                     f"sliding_{self.name}_penetration_mm": self.penetration()} | extra

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
