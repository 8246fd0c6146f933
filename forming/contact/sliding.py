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
  fades to zero over 30% of a facet (a cliff there made Newton cycle as an edge node
  stepped on and off the surface; 10% still cycled in the demonstrator).
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
* **Transfer to the master**: ``"area"`` spreads each node's force over its tributary
  area (:mod:`forming.contact.tributary`, passes the contact patch test); ``"point"``
  puts it at the node's closest point.
* **Stabilisation** (optional): a weak spring on each node's motion within the step,
  relative to the master point it began the step on.
* **Assembly**: outside the forms: each pair's residual on its 27 dofs (slave node, facet,
  history facet; with the area transfer also the facets its points reach) and its
  Jacobian by central differences (slidekernels.py), all pairs in one compiled call
  (slidebatch.py), are added to the solver's vector and matrix by global index
  (:class:`~forming.layout.Layout`); prescribed rows and columns are skipped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from forming.contact.nodal import critical_damping
from forming.contact.slidebatch import (
    damped_trial,
    distinct_facets,
    jacobian_all,
    jacobian_blocks,
    pair_all,
    residual_all,
)
from forming.contact.slidekernels import FADE
from forming.contact.slidesurface import INSIDE, Surface, node_normals, search_all
from forming.contact.terms import surface_edge_min
from forming.contact.tributary import AreaTransfer, bilinear_points
from forming.history import ForceSampler
from forming.layout import Layout
from forming.petscblocks import add_blocks
from forming.vectors import assembled


@dataclass(frozen=True)
class NormalDamping:
    """Viscous damping of a contact's normal approach (explicit runs).

    The trial pressure of each slave node gets ``-c dg/dt``, so a node that rings against
    its penalty spring loses ``c`` [MPa s/mm] times its approach speed, never pulls, and
    its friction limit follows the damped pressure.

    Attributes:
        coefficient: ``c`` per owned slave node [MPa s/mm].
        slave_velocity: The slave body's velocity array (3 per node), read at each use.
        master_velocity: The master body's velocity array (3 per node), read at each use.
    """

    coefficient: np.ndarray
    slave_velocity: np.ndarray
    master_velocity: np.ndarray


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
        self.elastic_slip = spec.elastic_slip * h
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
        self._paired_at: tuple[np.ndarray, np.ndarray] | None = None
        self._search_on_load = True
        self.seconds = 0.0  # wall time of the search and the pairs' evaluations [s]
        self.lam_n = np.zeros(n)
        self.p_new = np.zeros(n)
        self.gap = np.full(n, np.inf)
        self.shear = np.zeros((n, 3))
        self.force = np.zeros((n, 3))  # force on each slave node [N]
        self.spring = np.zeros((n, 3))  # stabilising force on each slave node [N]
        self.kappa = spec.stabilisation * self.penalty
        self.has_spring, self.spring_scale = self.kappa > 0.0, 1.0
        self.width = spec.smoothing * self.penalty * self.tolerance  # pressure ramp [MPa]
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
        self.openings = 0  # touched nodes that opened at a commit, since the last row
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
        """Pair the slave nodes (and the area transfer's points) at these positions.

        Skipped when nothing moved since the last pairing (the Jacobian after the
        residual at the same iterate): the walk could otherwise go one ring further and
        the Jacobian belong to another pairing than the residual.
        """
        last = self._paired_at
        if (not self._repair and last is not None and np.array_equal(last[0], xs)
                and np.array_equal(last[1], xm)):
            return
        self._paired_at = (xs.copy(), xm.copy())
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

    def add_residual(self, b: PETSc.Vec, damping: NormalDamping | None = None,
                     penalty_stick: bool = False) -> None:
        """Add the contact's residual to the solver's vector (global indices).

        Every pair in one compiled call (:func:`~forming.contact.slidebatch.residual_all`).
        With ``damping`` (explicit runs) each pair's trial pressure also carries the
        viscous pressure ``-c dg/dt`` of its normal approach (:class:`NormalDamping`).
        With ``penalty_stick`` (explicit runs) a sticking node is held by the normal
        penalty instead of the elastic slip's ``mu p / s_el``: the traction is the
        history, and a stick stiffness that follows a ringing pressure ratchets it down
        (docs/theory.md, section 12).
        """
        t0 = time.perf_counter()
        xs = self._slave_positions()
        xm = self.master.positions()
        self._pair(xs, xm)
        on = np.flatnonzero(self.inside)
        lam_n = self.lam_n if damping is None else self._damped_trial(on, damping)
        for a in (self.p_new, self.shear, self.force, self.spring):
            a[:] = 0.0
        self.gap[:] = np.inf
        sp = self.spreading
        ptr, offsets, phi, pfacet, pxi = self._points()
        if sp is None:
            size = 27 * len(on)
        else:
            points = np.diff(sp.ptr)[on]
            size = int(np.sum(15 + 12 * np.minimum(points, len(self.master.facets))))
        rows = np.empty(size, dtype=np.int64)
        values = np.empty(size)
        n = residual_all(on, xs, xm, self.master.facets, self.master.index, self.s_index,
                         self.facet, self.xi, self.hist, self.hist_xi, self.touched, self.rel,
                         lam_n, self.lam_t, self.node_normal, self.master.open_sides,
                         self.area, self.penalty, self.friction,
                         0.0 if penalty_stick else self.elastic_slip,
                         self.kappa, self.width, sp is not None, ptr, offsets, phi, pfacet, pxi,
                         rows, values, self.gap, self.p_new, self.shear, self.force,
                         self.spring)
        keep = rows[:n] >= 0  # (a vector does not skip negative indices as a matrix does)
        b.setValues(rows[:n][keep].astype(PETSc.IntType), values[:n][keep],
                    addv=PETSc.InsertMode.ADD_VALUES)
        self.seconds += time.perf_counter() - t0
        b.assemblyBegin()
        b.assemblyEnd()

    def _damped_trial(self, on: np.ndarray, damping: NormalDamping) -> np.ndarray:
        """The normal multipliers plus ``-c dg/dt`` at the pairs ``on``.

        ``dg/dt = (v_s - v_m) . n`` with the master's velocity and the smoothed normal at
        the paired point (as the kernel interpolates them), at the pairs that penetrated
        at the last evaluation (an approaching node is not pushed before it touches).
        """
        out = self.lam_n.copy()
        damped_trial(on, self.master.facets, self.facet, self.xi, self.node_normal,
                     self.master.gather(damping.master_velocity),
                     damping.slave_velocity.reshape(-1, 3), self.nodes, self.gap,
                     damping.coefficient, out)
        return out

    def damping(self, zeta: float, slave_mass: np.ndarray, slave_velocity: np.ndarray,
                master_velocity: np.ndarray) -> NormalDamping:
        """Normal damping at ``zeta`` of critical for each slave node on the penalty spring.

        Args:
            zeta: Fraction of critical damping.
            slave_mass: The slave body's lumped masses (3 per node) [t].
            slave_velocity: The slave body's velocities (3 per node; read at each call).
            master_velocity: The master body's velocities (3 per node; read at each call).
        """
        areal = slave_mass.reshape(-1, 3)[self.nodes, 0] / self.area
        return NormalDamping(critical_damping(zeta, self.penalty, areal), slave_velocity,
                             master_velocity)

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """Add the contact's Jacobian to the solver's matrix (global indices).

        Every pair's block computed in one compiled call
        (:func:`~forming.contact.slidebatch.jacobian_all`), then added block by block.
        """
        t0 = time.perf_counter()
        xs = self._slave_positions()
        xm = self.master.positions()
        self._pair(xs, xm)
        on = np.flatnonzero(self.inside)
        ptr, offsets, phi, pfacet, pxi = self._points()
        if self.spreading is None:
            nk = np.zeros(len(on), dtype=np.int64)
            nrow = ncol = np.full(len(on), 27, dtype=np.int64)
            nval = nrow * ncol
        else:
            nk = distinct_facets(on, ptr, pfacet)
            nrow, ncol, nval = 15 + 12 * nk, 27 + 39 * nk, 405 + 468 * nk
        row_at, col_at, val_at = (np.concatenate([[0], np.cumsum(v)]).astype(np.int64)
                                  for v in (nrow, ncol, nval))
        rows = np.empty(row_at[-1], dtype=np.int64)
        cols = np.empty(col_at[-1], dtype=np.int64)
        values = np.empty(val_at[-1])
        jacobian_all(on, xs, xm, self.master.facets, self.master.index, self.s_index,
                     self.facet, self.xi, self.hist, self.hist_xi, self.touched, self.rel,
                     self.lam_n, self.lam_t, self.node_normal, self.master.open_sides,
                     self.area, self.penalty, self.friction, self.elastic_slip, self.kappa,
                     self.width, self.spreading is not None, ptr, offsets, phi, pfacet, pxi,
                     row_at, col_at, val_at, rows, cols, values)
        add_blocks(A, jacobian_blocks(nk, row_at, col_at, val_at, self.spreading is not None),
                   rows, cols, values)
        self.seconds += time.perf_counter() - t0
        A.assemble()

    def _points(self):
        """The area transfer's points (empty arrays for the point transfer)."""
        sp = self.spreading
        if sp is None:
            empty = np.zeros(1, dtype=np.int64)
            return empty, np.zeros((0, 3)), np.zeros(0), empty, np.zeros((0, 2))
        return sp.ptr, sp.offsets, sp.phi, sp.facet, sp.xi

    # -- augmented Lagrangian and history --------------------------------------------------
    def _max(self, values: np.ndarray) -> float:
        return self.comm.allreduce(float(values.max()) if values.size else 0.0, op=MPI.MAX)

    def penetration(self) -> float:
        """Largest penetration of a slave node into the master [mm] (last evaluation).

        Weighted like :meth:`violation` by the share the master holds: a node let go past
        the master's edge is measured against the facet's extension, not against the
        master, and its "penetration" (millimetres where a skin bends round the core's
        edge) is none.
        """
        ok = np.isfinite(self.gap)
        return max(self._max(-(self._held()[ok] * self.gap[ok])), 0.0)

    def pressure_range(self) -> tuple[float, float]:
        """Smallest and largest nodal pressure of the slave nodes in contact [MPa]."""
        p = self.p_new[self.inside & (self.p_new > 0.0)]
        lo = self.comm.allreduce(float(p.min()) if p.size else np.inf, op=MPI.MIN)
        return lo, self._max(p)

    def _sharp(self) -> np.ndarray:
        """The unsmoothed pressure ``max(0, lambda_N - eps g)`` of the last evaluation.

        The Uzawa update takes it even when the ramp is smoothed: its fixed point is then
        exact complementarity, and the smoothing only changes the Newton iterates.
        """
        if self.width <= 0.0:
            return self.p_new
        return np.maximum(self.lam_n - self.penalty * self.gap, 0.0)  # (gap inf: not paired)

    def _held(self) -> np.ndarray:
        """The share of each slave node's force the master carries (as the kernel's fade).

        1 on the master surface; beyond its edge it falls to 0 over ``FADE`` of a facet.
        """
        sides = self.master.open_sides[self.facet]
        xi, eta = self.xi[:, 0], self.xi[:, 1]
        beyond = np.max(sides * np.column_stack([-1.0 - xi, xi - 1.0, -1.0 - eta,
                                                 eta - 1.0]), axis=1)
        return np.where(beyond > 0.0, np.clip(1.0 - beyond / FADE, 0.0, 1.0), 1.0)

    def violation(self) -> float:
        """Largest change of a normal multiplier over the penalty [mm].

        Weighted by the share of the force the master carries: a node let go beyond the
        master's edge is not held, so its penetration is not a violation (counted in
        full, it kept the demonstrator's Uzawa loop from ever ending: 96 tolerances at a
        top-skin node past the core's edge).
        """
        return self._max(self._held() * np.abs(self._sharp() - self.lam_n)) / self.penalty

    def augment(self) -> None:
        """Uzawa update of the normal multipliers (none for a node let go entirely)."""
        self.lam_n[:] = np.where(self._held() > 0.0, self._sharp(), 0.0)

    def scale_spring(self, scale: float) -> None:
        """Set the stabilising spring to ``scale`` times its setting (forming.springs)."""
        self.kappa, self.spring_scale = scale * self.spec.stabilisation * self.penalty, scale

    def commit(self) -> None:
        """Accept the step: the touched master points and the shear become history."""
        xs = self._slave_positions()
        xm = self.master.positions()
        now = self.inside & (self.p_new > 0.0)
        self.openings += int(np.count_nonzero(self.touched & ~now))
        self.touched[:] = now
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
        """Force of the master on the slave [N] (x, y, z), normal force, penetration [mm].

        Also ``openings``: how often a touching node opened at a commit since the last
        row (an explicit run commits every increment: nodes that chatter on the penalty
        spring lose their friction history at each opening).
        """
        f = self.comm.allreduce(self.force.sum(axis=0), op=MPI.SUM)
        openings = self.comm.allreduce(self.openings, op=MPI.SUM)
        self.openings = 0
        fn = self.comm.allreduce(float(self.area @ self.p_new), op=MPI.SUM)
        extra = {}
        if self.kappa > 0.0:
            spring = self.comm.allreduce(self.spring.sum(axis=0), op=MPI.SUM)
            extra = {f"sliding_{self.name}_stabilisation_N": float(np.linalg.norm(spring))}
        return {f"sliding_{self.name}_{axis}_N": float(f[k]) for k, axis in enumerate("xyz")
                } | {f"sliding_{self.name}_normal_N": fn,
                     f"sliding_{self.name}_penetration_mm": self.penetration(),
                     f"sliding_{self.name}_openings": float(openings)} | extra

    def max_slip(self) -> float:
        """Largest distance of a slave node from the master point it started on [mm]."""
        xs = self._slave_positions()
        start = self._point(self.master.positions(), self._start, self._start_xi)
        return self._max(np.linalg.norm(xs - start, axis=1))

    def warnings(self) -> list[str]:
        """Nothing to warn about: the pairing follows any slip."""
        return []
