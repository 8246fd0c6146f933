"""A body's surface in contact with itself: cell walls that fold onto each other.

When a honeycomb is crushed past its plateau, the folds of neighbouring walls, and of
one wall, meet (the densification of the C365 curve). The scene's
:class:`~forming.scene_contact.SelfContact` names the surface group whose faces may
touch; :class:`SurfaceSelfContact` is that surface at run time: the group's faces on
the body split into triangles over its nodes (a quadratic hexahedron's face into eight
around its centre node, a linear one's into two), with the search of :mod:`.selflist` and
the forces of :mod:`.selfkernels`.

The explicit solver enforces the contact by penalty (:class:`SelfContactTerm`): every
surface node is a slave of every triangle not on a cell of its own, with the soft
penalty ``stiffness m / dt^2`` of explicit codes (``m`` the pair's reduced mass).
An implicit run does not enforce it:
it stops, saying so, at the first converged step in which the surface meets itself
(:meth:`SurfaceSelfContact.meeting`), instead of letting walls pass through each other.

In parallel every rank holds the whole surface (node positions gathered at each
evaluation, triangles and cell adjacency once), tests its own nodes, and the forces
are summed over ranks: cheap for a meso patch, whose surface is a small share of its
unknowns.
"""

from __future__ import annotations

import basix
import numpy as np
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401
from forming.contact.selfkernels import (
    HIT_RADIUS,
    pair_shares,
    penalty_residual,
    penetrations,
)
from forming.contact.selflist import VerletList, candidates
from forming.errors import InputError
from forming.scene_contact import SelfContact

ONSET = 0.1  # deepest start of a contact, a fraction of the search depth
_HEX_EDGES = np.array(basix.topology(basix.CellType.hexahedron)[1])


class SurfaceSelfContact:
    """The surface of a :class:`SelfContact` at run time (collective construction).

    Args:
        spec: What touches.
        body: The model body (a solid on hexahedra).

    Raises:
        InputError: Not a hexahedral body.
    """

    def __init__(self, spec: SelfContact, body):
        msh = body.mesh
        if msh.topology.cell_name() != "hexahedron":
            raise InputError(f"self_contact.{spec.body}", "needs a body of hexahedra")
        self.spec = spec
        self.body = body
        self.comm = comm = msh.comm
        V = body.V
        imap = V.dofmap.index_map
        tris, tri_cell, pairs, depth = self._local_surface(spec, body)
        gather = comm.allgather if comm.size > 1 else (lambda a: [a])
        tris_g = np.concatenate(gather(tris))
        self.tri_cell = np.ascontiguousarray(np.concatenate(gather(tri_cell)))
        nodes = np.unique(tris_g)  # global block indices of the surface nodes
        self.tris = np.ascontiguousarray(np.searchsorted(nodes, tris_g))
        pairs = np.concatenate(gather(pairs))
        pairs = pairs[np.isin(pairs[:, 0], nodes)]
        pairs = np.unique(pairs, axis=0)
        row = np.searchsorted(nodes, pairs[:, 0])
        self.ptr = np.zeros(nodes.size + 1, dtype=np.int64)
        np.add.at(self.ptr, row + 1, 1)
        self.ptr = np.cumsum(self.ptr)
        self.cells = np.ascontiguousarray(pairs[np.argsort(row, kind="stable"), 1])
        self.depth = float(spec.depth) if spec.depth is not None else comm.allreduce(
            depth, op=MPI.MIN)
        # the rank's owned surface nodes: their local blocks and their rows
        globals_ = imap.local_to_global(np.arange(imap.size_local, dtype=np.int32))
        mine = np.isin(globals_, nodes)
        self.own_blocks = np.flatnonzero(mine).astype(np.int64)
        self.own_rows = np.searchsorted(nodes, globals_[mine]).astype(np.int64)
        self._counts = np.array(gather(self.own_rows.size), dtype=np.int64)
        order = np.concatenate(gather(self.own_rows))
        self._order = order  # row of each gathered entry
        self.n = nodes.size
        self.x_ref = self._gather(V.tabulate_dof_coordinates()[self.own_blocks])
        self.mass: np.ndarray | None = None
        self.pairs = 0  # pairs in contact at the last evaluation
        self.penetration = 0.0  # deepest penetration at the last evaluation [mm]
        self.verlet = VerletList(self.tris, self.tri_cell, self.ptr, self.cells,
                                 self.own_rows, HIT_RADIUS * self.depth, self.depth)
        # per own slave: its triangle at the last evaluation (-1: none), its elastic
        # normal force [N] and signed distance [mm] (the rate-form penalty)
        self.pair_state = np.zeros((self.own_rows.size, 3))
        self.pair_state[:, 0] = -1.0
        self._eroded = -1  # eroded cells (all ranks) when the list was last updated
        self.deepest = 0.0  # deepest penetration of the run so far [mm]

    @staticmethod
    def _local_surface(spec: SelfContact, body):
        """This rank's triangles (global nodes), their cells, node-cell pairs, depth."""
        msh, V = body.mesh, body.V
        tdim = msh.topology.dim
        msh.topology.create_connectivity(tdim - 1, tdim)
        msh.topology.create_connectivity(tdim, tdim - 1)
        f2c = msh.topology.connectivity(tdim - 1, tdim)
        c2f = msh.topology.connectivity(tdim, tdim - 1)
        n_own = body.n_local_cells
        element = V.ufl_element().basix_element
        closure = element.entity_closure_dofs[2]
        centre = element.entity_dofs[2]
        imap = V.dofmap.index_map
        cmap = msh.topology.index_map(tdim)
        x_all = V.tabulate_dof_coordinates()
        dofs = V.dofmap.list
        tris, tri_cell = [], []
        edge = np.inf
        for f in body.domain.facets(spec.region):
            c = int(f2c.links(f)[0])
            if c >= n_own:
                continue  # another rank owns the face's cell
            local = int(np.flatnonzero(c2f.links(c) == f)[0])
            cell_dofs = dofs[c]
            face = cell_dofs[closure[local]]
            mid = cell_dofs[centre[local]] if len(centre[local]) else np.zeros(0, np.int32)
            inside = x_all[cell_dofs].mean(axis=0)
            ring = face[~np.isin(face, mid)]
            tris += _fan(x_all, ring, mid, inside)
            tri_cell += [c] * (len(ring) if mid.size else len(ring) - 2)
            geo = msh.geometry.x[msh.geometry.dofmaps[0][c]]
            edge = min(edge, float(np.min(np.linalg.norm(
                geo[_HEX_EDGES[:, 0]] - geo[_HEX_EDGES[:, 1]], axis=1))))
        tris = np.array(tris, dtype=np.int32).reshape(-1, 3)
        tris_g = imap.local_to_global(tris.ravel()).reshape(-1, 3)
        cell_g = cmap.local_to_global(np.array(tri_cell, dtype=np.int32))
        # (node, cell) pairs of every owned cell: the cells a surface node belongs to
        own = dofs[:n_own]
        node_g = imap.local_to_global(own.ravel().astype(np.int32))
        cells_g = np.repeat(cmap.local_to_global(np.arange(n_own, dtype=np.int32)),
                            own.shape[1])
        pairs = np.column_stack([node_g, cells_g]).astype(np.int64)
        return tris_g.astype(np.int64), cell_g.astype(np.int64), pairs, 0.5 * edge

    def _gather(self, local: np.ndarray) -> np.ndarray:
        """(n, 3) array of every surface node from each rank's owned rows (collective)."""
        out = np.empty((self.n, 3))
        if self.comm.size == 1:
            out[self.own_rows] = local
            return out
        buf = np.empty((int(self._counts.sum()), 3))
        self.comm.Allgatherv(np.ascontiguousarray(local, dtype=float),
                             [buf, 3 * self._counts, MPI.DOUBLE])
        out[self._order] = buf
        return out

    def positions(self, u: np.ndarray) -> np.ndarray:
        """Current coordinates of every surface node (collective).

        Args:
            u: The body's displacement array (3 per local node).
        """
        return self.x_ref + self._gather(u.reshape(-1, 3)[self.own_blocks])

    def _search(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Penetrations at ``x``, from the candidate list (kept exact as nodes move).

        The faces of cells that eroded on any rank leave the list at once (collective).
        """
        eroded = self._eroded_cells()
        if eroded != self._eroded:
            self._eroded = eroded
            self.verlet.erode(*self._dead())
        offsets, cand = self.verlet.update(x)
        return penetrations(x, self.tris, self.own_rows, offsets, cand, self.depth, False,
                            self.pair_state[:, 0] >= 0, ONSET * self.depth)

    def _eroded_cells(self) -> int:
        """How many cells of the body have eroded, over all ranks (collective)."""
        body = self.body
        count = (int(np.count_nonzero(~body.live_cells()))
                 if getattr(body, "damaging", False) else 0)
        return self.comm.allreduce(count, op=MPI.SUM) if self.comm.size > 1 else count

    def _dead(self) -> tuple[np.ndarray, np.ndarray]:
        """Triangles on eroded cells, and nodes of eroded cells only (collective).

        An eroded cell (every point of a fracturing body's cell spent) carries no stress
        and is no obstacle: as the explicit codes delete failed elements, its faces and
        the nodes it alone holds leave the contact.
        """
        body = self.body
        tri_dead = np.zeros(len(self.tris), dtype=bool)
        node_dead = np.zeros(self.n, dtype=bool)
        if not getattr(body, "damaging", False):
            return tri_dead, node_dead
        cmap = body.mesh.topology.index_map(body.mesh.topology.dim)
        dead = cmap.local_to_global(
            body.point_cells[~body.live_cells()].astype(np.int32)).astype(np.int64)
        if self.comm.size > 1:
            dead = np.concatenate(self.comm.allgather(dead))
        if dead.size == 0:
            return tri_dead, node_dead
        tri_dead = np.isin(self.tri_cell, dead)
        cell_dead = np.isin(self.cells, dead)
        alive = np.add.reduceat(~cell_dead, self.ptr[:-1]) if self.cells.size else 0
        node_dead = (alive == 0) & (np.diff(self.ptr) > 0)
        return tri_dead, node_dead

    def set_pair_state(self, state: np.ndarray) -> None:
        """Return the slaves' pair state to ``state`` (a restored snapshot).

        The candidate list is searched afresh at the next evaluation.
        """
        self.pair_state[:] = state
        self.verlet.forget()
        self._eroded = -1

    def set_masses(self, m: np.ndarray) -> None:
        """Take the lumped masses of the body's nodes (3 per node; after mass scaling)."""
        self.mass = self._gather(m.reshape(-1, 3)[self.own_blocks])[:, 0].copy()

    def residual(self, u: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
        """Penalty forces as residual entries of the rank's owned surface nodes (collective).

        Args:
            u: The body's displacement array.
            v: The body's velocity array (the contact damping).
            dt: The explicit time step [s].

        Returns:
            (n_owned_surface_nodes, 3) residual entries, in :attr:`own_blocks` order.
        """
        if self.mass is None:
            raise RuntimeError("set_masses() first")
        x = self.positions(u)
        hit, dist, bary, normal = self._search(x)
        r = np.zeros((self.n, 3))
        vel = self._gather(v.reshape(-1, 3)[self.own_blocks])
        share = np.zeros(self.n)
        pair_shares(self.own_rows, hit, dist, bary, self.tris, share)
        if self.comm.size > 1:
            self.comm.Allreduce(MPI.IN_PLACE, share, op=MPI.SUM)
        pairs, deepest = penalty_residual(x, self.own_rows, hit, dist, bary, normal,
                                          self.tris, self.mass, vel, share,
                                          self.spec.stiffness, self.spec.damping, dt,
                                          self.pair_state, r)
        if self.comm.size > 1:
            self.comm.Allreduce(MPI.IN_PLACE, r, op=MPI.SUM)
            pairs = self.comm.allreduce(pairs, op=MPI.SUM)
            deepest = self.comm.allreduce(deepest, op=MPI.MAX)
        self.pairs = int(pairs)
        self.penetration = float(deepest)
        self.deepest = max(self.deepest, self.penetration)
        return r[self.own_rows]

    def meeting(self, u: np.ndarray) -> tuple[int, float]:
        """Surface nodes behind a face of another cell, within the search depth (collective).

        What a solver that does not enforce the contact checks after a step. A node that
        crossed a face by more than the depth within one step is not seen.

        Returns:
            (how many, the deepest signed distance [mm], negative).
        """
        x = self.positions(u)
        listed = candidates(x, self.tris, self.tri_cell, self.ptr, self.cells,
                            self.own_rows, HIT_RADIUS * self.depth, *self._dead())
        hit, dist, _b, _n = penetrations(x, self.tris, self.own_rows, *listed, self.depth,
                                         False, np.zeros(self.own_rows.size, dtype=bool),
                                         self.depth)
        inside = hit >= 0
        count = self.comm.allreduce(int(inside.sum()), op=MPI.SUM)
        deepest = self.comm.allreduce(float(dist[inside].min(initial=0.0)), op=MPI.MIN)
        return count, deepest


def _fan(x: np.ndarray, ring: np.ndarray, mid: np.ndarray, inside: np.ndarray) -> list:
    """Triangles of a face: a fan around its centre node (or its first corner).

    The ring's nodes are sorted by angle around the face's centre; each triangle is
    oriented so that its normal points away from the cell (``inside``).
    """
    pts = x[ring]
    c = x[mid[0]] if mid.size else pts.mean(axis=0)
    a = pts[0] - c
    nrm = np.cross(pts[1] - c, a)
    nrm = nrm if np.linalg.norm(nrm) > 0 else np.cross(pts[2] - c, a)
    b = np.cross(nrm, a)
    ang = np.arctan2((pts - c) @ b, (pts - c) @ a)
    ring = ring[np.argsort(ang)]
    if mid.size:
        tris = [(mid[0], ring[i], ring[(i + 1) % len(ring)]) for i in range(len(ring))]
    else:
        tris = [(ring[0], ring[i], ring[i + 1]) for i in range(1, len(ring) - 1)]
    out = []
    for t in tris:
        p = x[list(t)]
        if np.cross(p[1] - p[0], p[2] - p[0]) @ (p[0] - inside) < 0:
            t = (t[0], t[2], t[1])
        out.append(t)
    return out


class SelfContactTerm:
    """A self-contact in the explicit solver: penalty forces, kept as a residual term.

    It has the interface of the solver's assembled terms (``vec``, ``r_old``,
    ``r_new``, ``update``), so its work enters the energy ledger as that of the
    contact and interface terms do.

    Args:
        state: The body's explicit state (:class:`~forming.solver.lumped.BodyState`).
        surface: The self-contact surface.
        time_step: Callable giving the current time step [s].
    """

    def __init__(self, state, surface: SurfaceSelfContact, time_step):
        self.state = state
        self.surface = surface
        self._time_step = time_step
        self.vec = fem.Function(state.body.V)
        self.r_old = np.zeros(state.n_owned)
        self._ready = False

    def update(self) -> None:
        """Keep the last residual, evaluate the new one."""
        if not self._ready:  # the masses after the solver's mass scaling
            self.surface.set_masses(self.state.m)
            self._ready = True
        n = self.state.n_owned
        self.r_old[:] = self.vec.x.array[:n]
        r = self.surface.residual(self.state.body.u.x.array, self.state.v, self._time_step())
        arr = self.vec.x.array
        arr[:] = 0.0
        blocks = self.surface.own_blocks
        arr.reshape(-1, 3)[blocks] = r
        self.vec.x.scatter_forward()

    @property
    def r_new(self) -> np.ndarray:
        """The term's owned entries as last evaluated."""
        return self.vec.x.array[: self.state.n_owned]

    def pair_state_vector(self) -> np.ndarray:
        """The slaves' pair state as an array of the body's vector (a snapshot).

        Per node: its triangle (-1: none), elastic normal force and signed distance.
        """
        out = np.zeros_like(self.vec.x.array)
        out.reshape(-1, 3)[self.surface.own_blocks] = self.surface.pair_state
        return out

    def set_pair_state_vector(self, arr: np.ndarray) -> None:
        """Return the slaves' pair state to a snapshot's."""
        self.surface.set_pair_state(arr.reshape(-1, 3)[self.surface.own_blocks])
