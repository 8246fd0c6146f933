"""Augmented-Lagrangian frictional contact of a body's surface with a rigid tool.

Nodal contact: the terms are integrated with the vertex rule (a quadratic body's faces:
the Gauss-Lobatto rule at their nodes), so gaps, pressures and tangential tractions live
at the surface nodes, held in multiplier functions of the body's degree
(``lambda_N``, and ``lambda_T`` when the pair has friction). Within a Newton solve the
multipliers are fixed; between solves (Uzawa) they are set to the tractions the
solution produced, until the constraint violation is below the tolerance. See
``docs/theory.md``.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, mesh  # noqa: I001
from mpi4py import MPI

from forming import compat
from forming.contact.base import default_penalty
from forming.contact.exposed import ExposedSurface
from forming.contact.laws import coulomb_return, normal_pressure, tangent_projector
from forming.contact.nodal import NodalContact
from forming.contact.shapes import UFL
from forming.contact.tracking import ClosestPoints
from forming.history import MAX_PENETRATION, ForceSampler, force_column
from forming.scene import Contact, Tool
from forming.vectors import assembled


def _extent(msh) -> float:
    """Largest extent of a mesh's bounding box, over all ranks [mm]."""
    x = msh.geometry.x
    local = np.concatenate([-x.min(axis=0), x.max(axis=0)]) if len(x) else np.full(6, -np.inf)
    both = np.empty(6)
    msh.comm.Allreduce(local, both, op=MPI.MAX)
    return float(np.max(both[3:] + both[:3]))


def surface_edge_min(msh, facets: np.ndarray) -> float:
    """Shortest edge length of the given facets, over all ranks [mm]."""
    msh.topology.create_connectivity(2, 1)
    msh.topology.create_connectivity(1, 3)
    edges = mesh.compute_incident_entities(msh.topology, facets.astype(np.int32), 2, 1)
    local = float(msh.h(1, edges).min()) if edges.size else np.inf
    return msh.comm.allreduce(local, op=MPI.MIN)


def nodal_rule(degree: int) -> dict[str, object]:
    """Quadrature metadata whose points are a face's nodes, for a field of ``degree``.

    The vertex rule on linear faces; on quadratic ones the Gauss-Lobatto rule whose
    points are the face's 9 nodes (Simpson weights, all positive), so that every node of
    the face carries its share, not only the corners. Corner-only contact leaves a
    quadratic face's other nodes free: 6 times too compliant against a tool
    (tests/test_explicit.py), 5.7 times across a bonded interface (tests/test_interfaces.py).
    """
    if degree == 1:
        return {"quadrature_rule": "vertex", "quadrature_degree": 1}
    return {"quadrature_rule": "GLL", "quadrature_degree": 3}  # Body accepts 1 or 2 only


class ContactTerm:
    """Contact between a surface region of a body and one rigid tool.

    Args:
        spec: The scene's contact pair.
        tool: The tool it refers to.
        body: The body whose surface touches (a
            :class:`~forming.bodies.base.DeformableBody`).
        thickness: Smallest extent of the body [mm] (caps the default tolerance).
        penalty_only: Whether the solver enforces it by the penalty alone (explicit runs:
            a stiffer default penalty, :func:`~forming.contact.base.default_penalty`).
    """

    def __init__(self, spec: Contact, tool: Tool, body, thickness: float,
                 penalty_only: bool = False):
        self.spec = spec
        self.tool = tool
        self.body = body
        self.name = tool.name
        self.bodies = (spec.body,)
        msh = body.mesh  # the body's own mesh (multipliers, nodal evaluation)
        parent = body.domain.md.mesh  # the scene mesh (forms)
        self.comm = msh.comm
        facets = body.domain.facets(spec.region)
        tool.shape.check_units(_extent(msh))
        # a surface-mesh tool: closest points tracked node by node (tracking.py)
        self._track = ClosestPoints(tool.shape, body, facets) if tool.shape.tracked else None
        h = surface_edge_min(msh, facets)
        self.tolerance = spec.tolerance or 0.01 * min(h, thickness)
        stiffness = body.contact_stiffness()
        default = default_penalty(stiffness, h, thickness, penalty_only)
        self.penalty = spec.penalty or (default if penalty_only else default * spec.penalty_scale)
        self.friction = spec.friction
        # elastic slip of the penalty stick law (None: augmented stick constraint)
        self.elastic_slip = 0.005 * h if spec.stick == "elastic_slip" else None
        # nodal integration (the face's nodes are the quadrature points)
        degree = body.spec.degree if self._track is None else 1
        self._ds = body.domain.ds(spec.region, **nodal_rule(degree))
        self._rule = nodal_rule(degree)
        self.exposed: ExposedSurface | None = None  # see nodal()
        self._nodal: NodalContact | None = None  # the node-by-node form, once built
        W = fem.functionspace(msh, ("Lagrange", degree))
        self.lam_n = fem.Function(W, name=f"pressure_{tool.name}")
        self._offset = fem.Constant(parent, np.zeros(3))
        self._offset_now = self._offset.value  # a view (the property costs ~2 us a call)
        self._eps = fem.Constant(parent, self.penalty)
        self.lam_t = None
        Wv = None
        if self.friction > 0.0:  # a frictionless pair compiles no tangential terms
            Wv = fem.functionspace(msh, ("Lagrange", degree, (3,)))
            self.lam_t = fem.Function(Wv, name=f"shear_{tool.name}")
            self.u_prev = fem.Function(body.V)
            self._offset_prev = fem.Constant(parent, np.zeros(3))
        # the same expressions with the coordinates of the scene mesh (forms) and of the
        # body's own mesh (nodal evaluation); identical for a body on the whole mesh
        self.gap, self.normal, self.pressure, self.shear, self.traction = self._terms(
            ufl.SpatialCoordinate(parent))
        own = self._terms(ufl.SpatialCoordinate(msh)) if body.domain.is_submesh else (
            self.gap, self.normal, self.pressure, self.shear, self.traction)
        gap_own, _n, pressure_own, shear_own, _t = own
        # nodal evaluation on the cells next to the region
        msh.topology.create_connectivity(2, 3)
        self._cells = mesh.compute_incident_entities(msh.topology, facets.astype(np.int32),
                                                     2, 3)
        self._dofs = fem.locate_dofs_topological(W, 2, facets)
        self._owned = self._dofs[self._dofs < W.dofmap.index_map.size_local]
        pts = W.element.interpolation_points
        self._gap_expr = compat.expression(gap_own, pts)
        self._p_expr = compat.expression(pressure_own, pts)
        self._gap = fem.Function(W)
        self._p_new = fem.Function(W)
        if self.lam_t is not None:
            self._t_expr = compat.expression(shear_own, Wv.element.interpolation_points)
            self._t_new = fem.Function(Wv)
        form = body.domain.form
        self._force_forms = [form(-self.traction[i] * self._ds) for i in range(3)]
        self._area_form = form(ufl.conditional(ufl.gt(self.pressure, 0.0), 1.0, 0.0)
                               * self._ds)
        self._warnings: list[str] = []

    def _terms(self, x):
        """Gap, normal, pressure, shear (None without friction) and traction at ``x``."""
        u = self.body.u
        p = ufl.variable(x + u - self._offset)
        if self._track is None:
            gap = self.tool.shape.distance(p, UFL)
            grad = ufl.diff(gap, p)
            normal = grad / ufl.sqrt(ufl.dot(grad, grad) + 1e-30)
        else:  # a surface mesh: the tracked closest point (tracking.py)
            gap = ufl.dot(self._track.normal, p - self._track.closest)
            normal = self._track.direction(p)
        pressure = normal_pressure(self.lam_n - self._eps * gap)
        traction = pressure * normal
        shear = None
        if self.lam_t is not None:
            proj = tangent_projector(normal)
            slip = proj * (u - self.u_prev - (self._offset - self._offset_prev))
            limit = self.friction * pressure
            # augmented: the stick constraint's penalty; elastic slip: mu p / s_el, which
            # vanishes with the pressure (docs/theory.md, section 11)
            k_t = self._eps if self.elastic_slip is None else limit / self.elastic_slip
            # stick up to the cone (+1e-12 MPa)
            shear = coulomb_return(proj * self.lam_t - k_t * slip, limit, slack=1e-12)
            traction = traction + shear
        return gap, normal, pressure, shear, traction

    # -- forms -------------------------------------------------------------------------
    def residuals(self, tests: dict) -> dict[str, ufl.Form]:
        """Virtual work of the contact traction (an external force on the body)."""
        v = tests[self.spec.body]
        return {self.spec.body: -ufl.dot(self.traction, v) * self._ds}

    def stiffness_estimate(self, tests: dict) -> dict[str, ufl.Form]:
        """The penalty on every node of the region, touching or not (explicit time step)."""
        w = tests[self.spec.body]
        return {self.spec.body: self._eps * ufl.dot(ufl.as_vector([1.0, 1.0, 1.0]), w)
                * self._ds}

    # -- load programme ----------------------------------------------------------------
    def set_load(self, t: float) -> None:
        """Move the tool to its position at load parameter ``t``."""
        self._offset_now[:] = self.tool.offset(t)
        if self._track is not None:  # a new load step: search the tree again
            self._track.repair()

    def track(self) -> None:
        """Closest points of the current configuration on a surface-mesh tool."""
        if self._track is not None:
            self._track.update(self._offset.value)

    def tool_offset(self) -> np.ndarray:
        """Current displacement of the tool from its initial position [mm]."""
        return self._offset_now.copy()

    # -- augmentation ------------------------------------------------------------------
    def _reduce_max(self, values: np.ndarray) -> float:
        local = float(values.max()) if values.size else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    def penetration(self) -> float:
        """Largest penetration of a surface node into the tool [mm] (0 if none).

        On an eroding body in an explicit run, the nodes of the surface erosion has left
        (:attr:`exposed`), not the group's nodes on eroded cells.
        """
        if self.exposed is not None:
            nc = self._nodal
            on = nc.area > 0.0
            x = nc.coords[on] + self.body.u.x.array.reshape(-1, 3)[nc.nodes[on]]
            gap = nc.shape.gap_normal(x - self.tool_offset())[0]
            return max(self._reduce_max(-gap), 0.0)
        self.track()
        self._gap.interpolate(self._gap_expr, cells0=self._cells)
        return max(self._reduce_max(-self._gap.x.array[self._owned]), 0.0)

    def violation(self) -> float:
        """Constraint violation of the current solution [mm].

        Evaluates the tractions the solution produced (the next Uzawa multipliers) and
        returns the largest change of a multiplier over the penalty: the penetration of a
        pressed node, a multiplier left on a separated node, or the slip of a sticking one.
        """
        self._p_new.interpolate(self._p_expr, cells0=self._cells)
        own = self._owned
        change = np.abs(self._p_new.x.array[own] - self.lam_n.x.array[own])
        worst = self._reduce_max(change) / self.penalty
        if self.lam_t is not None and self.elastic_slip is None:
            self._t_new.interpolate(self._t_expr, cells0=self._cells)
            new = self._t_new.x.array.reshape(-1, 3)[own]
            old = self.lam_t.x.array.reshape(-1, 3)[own]
            worst = max(worst, self._reduce_max(np.linalg.norm(new - old, axis=1))
                        / self.penalty)
        return worst

    def augment(self) -> None:
        """Uzawa update: the multipliers become the tractions of :meth:`violation`."""
        d = self._dofs
        self.lam_n.x.array[d] = self._p_new.x.array[d]
        self.lam_n.x.scatter_forward()
        if self.lam_t is not None and self.elastic_slip is None:
            self.lam_t.x.array.reshape(-1, 3)[d] = self._t_new.x.array.reshape(-1, 3)[d]
            self.lam_t.x.scatter_forward()

    def commit(self) -> None:
        """Accept the step.

        The slip of the next step is measured from here, so the tangential multiplier
        takes the converged shear traction.
        """
        if self.lam_t is not None:
            self.track()
            self._t_new.interpolate(self._t_expr, cells0=self._cells)
            d = self._dofs
            self.lam_t.x.array.reshape(-1, 3)[d] = self._t_new.x.array.reshape(-1, 3)[d]
            self.lam_t.x.scatter_forward()
            self.u_prev.x.array[:] = self.body.u.x.array
            self._offset_prev.value[:] = self._offset.value

    def snapshot(self) -> tuple:
        """Copy of the multipliers and of the slip reference (the last converged state)."""
        if self.lam_t is None:
            return (self.lam_n.x.array.copy(), None, None, None)
        return (self.lam_n.x.array.copy(), self.lam_t.x.array.copy(),
                self.u_prev.x.array.copy(), self._offset_prev.value.copy())

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""
        if self._track is not None:
            self._track.repair()
        self.lam_n.x.array[:] = snap[0]
        if self.lam_t is not None:
            self.lam_t.x.array[:] = snap[1]
            self.u_prev.x.array[:] = snap[2]
            self._offset_prev.value[:] = snap[3]

    def snapshot_layout(self) -> tuple:
        """Layouts of the multipliers and the slip reference (the tool offset is global)."""
        dom = self.body.domain
        if self.lam_t is None:
            return (dom.layout(self.lam_n.function_space), None, None, None)
        return (dom.layout(self.lam_n.function_space), dom.layout(self.lam_t.function_space),
                dom.layout(self.u_prev.function_space), None)

    # -- node by node (explicit increments) ---------------------------------------------
    def nodal(self) -> NodalContact:
        """The same contact evaluated node by node (:mod:`forming.contact.nodal`).

        Its friction history starts from this term's (:meth:`pull_nodal`). It holds a
        sticking node with the penalty whatever ``stick`` says (:class:`NodalContact`).
        On a body whose elements erode (an analytic tool), its nodes are all the body's
        face nodes, with the areas of :attr:`exposed` (collective).
        """
        V = self.body.V
        facets = self.body.domain.facets(self.spec.region)
        # an eroding body: the tool meets what erosion uncovers (exposed.py); a tool of a
        # surface mesh tracks the group's nodes only
        if self.body.erodes and self._track is None:
            self.exposed = ExposedSurface(self.body, facets, self._rule)
            msh = self.body.mesh  # any face may be uncovered: the nodes of all of them
            msh.topology.create_entities(2)
            imap = msh.topology.index_map(2)
            facets = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
        nodes = fem.locate_dofs_topological(V, 2, facets)
        nodes = nodes[nodes < V.dofmap.index_map.size_local].astype(np.int64)
        if self.exposed is not None:
            area = self.exposed.areas(nodes)
        else:
            w = ufl.TestFunction(V)
            f = fem.Function(V)
            assembled(self.body.domain.form(ufl.dot(ufl.as_vector([1.0, 1.0, 1.0]), w)
                                            * self._ds), f)
            area = f.x.array[3 * nodes]
            # the nodes the rule integrates at (a tracked tool on a quadratic body: corners)
            nodes, area = nodes[area > 0.0], area[area > 0.0]
        nc = NodalContact(self.tool.shape, nodes, V.tabulate_dof_coordinates()[nodes],
                          area, self.penalty, self.friction)
        self._nodal = nc
        if self.lam_t is not None:  # blocks of the shear function at the nodes
            Wv = self.lam_t.function_space
            blocks = np.full(V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts, -1,
                             dtype=np.int64)
            # the shear's nodes: all of the body's, or its vertices (the first dofs of a
            # cell in either space)
            blocks[V.dofmap.list[:, : Wv.dofmap.list.shape[1]]] = Wv.dofmap.list
            self._shear_blocks = blocks[nodes]
        self.pull_nodal(nc)
        return nc

    def pull_nodal(self, nc: NodalContact) -> None:
        """Give a nodal contact this term's friction history (start, restored snapshot)."""
        if self.lam_t is None:
            return
        nc.lam_t[:] = self.lam_t.x.array.reshape(-1, 3)[self._shear_blocks]
        nc.u_prev[:] = self.u_prev.x.array.reshape(-1, 3)[nc.nodes]
        nc.offset_prev[:] = self._offset_prev.value

    def push_nodal(self, nc: NodalContact) -> None:
        """Take a nodal contact's friction history (outputs and snapshots see it)."""
        if self.lam_t is None:
            return
        self.lam_t.x.array.reshape(-1, 3)[self._shear_blocks] = nc.lam_t
        self.lam_t.x.scatter_forward()
        self.u_prev.x.array.reshape(-1, 3)[nc.nodes] = nc.u_prev
        self.u_prev.x.scatter_forward()
        self._offset_prev.value[:] = nc.offset_prev

    # -- outputs -----------------------------------------------------------------------
    def force(self) -> np.ndarray:
        """Force the body exerts on the tool [N] (a punch pushed down feels +z)."""
        self.track()
        return np.array([self.comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                         for f in self._force_forms])

    def nodal_pressure(self) -> tuple[np.ndarray, np.ndarray]:
        """Contact pressure [MPa] and reference coordinates of this rank's region nodes."""
        self.track()
        self._p_new.interpolate(self._p_expr, cells0=self._cells)
        x = self._p_new.function_space.tabulate_dof_coordinates()
        return self._p_new.x.array[self._owned].copy(), x[self._owned]

    def nodal_gap(self) -> tuple[np.ndarray, np.ndarray]:
        """Gap to the tool [mm] and reference coordinates of this rank's region nodes."""
        self.track()
        self._gap.interpolate(self._gap_expr, cells0=self._cells)
        x = self._gap.function_space.tabulate_dof_coordinates()
        return self._gap.x.array[self._owned].copy(), x[self._owned]

    def contact_area(self) -> float:
        """Area of the region in contact [mm^2] (nodal, vertex rule)."""
        self.track()
        return self.comm.allreduce(fem.assemble_scalar(self._area_form), op=MPI.SUM)

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """The force on the tool, as the solver samples it [N]."""
        f = forces.tool_force(self)
        return {force_column(self.name, i): float(f[i]) for i in range(3)}

    def warnings(self) -> list[str]:
        """None: a tool contact has nothing to warn about yet."""
        return list(self._warnings)


def penetration_column(contacts: list[ContactTerm]) -> dict[str, float]:
    """The largest penetration over every tool contact [mm] (no column without one)."""
    if not contacts:
        return {}
    return {MAX_PENETRATION: max(c.penetration() for c in contacts)}
