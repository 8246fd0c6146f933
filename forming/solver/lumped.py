"""What the explicit solver keeps per body: lumped mass, velocity and force vectors.

Row-sum lumping of a linear element's mass (or a quadratic hexahedron's: the 27-node
Lagrange element's row sums are products of the 1D ones, 1/6, 2/3, 1/6, all positive),
the vectors of one body's internal and external forces, and the contact and interface
tractions assembled on their own (for the energy ledger and the tool forces).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001

from forming import compat  # noqa: F401
from forming.contact.nodal import critical_damping
from forming.errors import InputError
from forming.vectors import assembled


def body_density(body) -> float:
    """Mass density of a model body [t/mm^3]: the scene body's, else its material's.

    Raises:
        InputError: Neither gives one.
    """
    rho = body.spec.density if body.spec.density is not None else getattr(
        body.material, "density", None)
    if rho is None:
        raise InputError(f"body.{body.spec.name}.density",
                         "the explicit solver needs a mass density (Body.density or the "
                         "material's density) [t/mm^3]")
    return float(rho)


class BodyState:
    """Velocity, acceleration, lumped mass and force vectors of one body."""

    def __init__(self, name: str, body, bcs: list[fem.DirichletBC]):
        self.name = name
        self.body = body
        V = body.V
        cell = body.mesh.topology.cell_name()
        if body.spec.degree != 1 and not (body.spec.degree == 2 and cell == "hexahedron"):
            raise InputError(f"body.{name}.degree",
                             "the explicit solver needs linear elements, or quadratic "
                             "hexahedra (row-sum lumping: other quadratic elements have "
                             "negative vertex masses)")
        self.n_owned = V.dofmap.index_map.size_local * 3
        self.bcs = bcs
        mask = np.zeros(body.u.x.array.size, dtype=bool)
        for bc in bcs:
            mask[bc.dof_indices()[0]] = True
        self.fixed = mask
        self.fixed_dofs = np.flatnonzero(mask)
        self.v = np.zeros_like(body.u.x.array)  # velocity at the half step
        self.a = np.zeros_like(self.v)
        self.f_int = fem.Function(V)  # internal forces (assembled, ghosts updated)
        self.f_all = fem.Function(V)  # full residual: internal minus external forces
        # views of the arrays every increment reads and writes: ``x.array`` builds a new
        # view at each call (about 2 us), and the vectors never reallocate
        self.u_arr = body.u.x.array
        self.f_int_arr = self.f_int.x.array
        self.f_all_arr = self.f_all.x.array
        rho = body_density(body)
        w = ufl.TestFunction(V)
        mass = body.domain.form(rho * ufl.dot(ufl.as_vector([1.0, 1.0, 1.0]), w) * body.dx)
        self.m_phys = assembled(mass)
        if np.any(self.m_phys[: self.n_owned] <= 0):
            raise InputError(f"body.{name}", "a node has no mass (empty lumped row)")
        self.m = self.m_phys.copy()


class ExternalTerm:
    """A contact or interface traction on one body, assembled alone (energy bookkeeping)."""

    def __init__(self, state: BodyState, form: fem.Form, contact=None):
        self.state = state
        self.form = form
        self.contact = contact  # the tool contact (a ContactTerm), None otherwise
        self.vec = fem.Function(state.body.V)
        self.r_old = np.zeros(state.n_owned)

    def update(self) -> None:
        """Keep the last residual, assemble the new one."""
        self.r_old[:] = self.vec.x.array[: self.state.n_owned]
        assembled(self.form, self.vec)

    @property
    def r_new(self) -> np.ndarray:
        """The term's owned entries as last assembled."""
        return self.vec.x.array[: self.state.n_owned]


class ViscousTerm(ExternalTerm):
    """A body's damping forces at the half-step velocities, assembled alone.

    Args:
        state: The body's explicit state.
        form: The damping forces' form, in the velocity ``v`` and the damping time.
        v: The velocity function the form reads (filled from ``state.v`` at each update).
        beta: The damping time [s] (set by the solver from the stable time step).
    """

    def __init__(self, state: BodyState, form: fem.Form, v: fem.Function,
                 beta: fem.Constant):
        super().__init__(state, form)
        self.v = v
        self.beta = beta

    def update(self) -> None:
        """The velocities into the form, then assemble."""
        self.v.x.array[:] = self.state.v
        super().update()


def viscous_terms(states: list[BodyState], tests: dict, emaps) -> list[ViscousTerm]:
    """The damping forces of every body that has them (:meth:`viscous_residual`)."""
    out = []
    for st in states:
        v = fem.Function(st.body.V)
        beta = fem.Constant(st.body.mesh, 0.0)
        form = st.body.viscous_residual(v, beta, tests[st.name])
        if form is not None:
            out.append(ViscousTerm(st, fem.form(form, entity_maps=emaps), v, beta))
    return out


class InterfaceSide(ExternalTerm):
    """One body's share of a damped interface: the velocities go in before assembly.

    Args:
        state: The body's explicit state.
        form: The damped traction's virtual work on this body.
        fills: (function, state) pairs: each state's half-step velocities are copied
            into its function before the form is assembled.
    """

    def __init__(self, state: BodyState, form: fem.Form, fills: list):
        super().__init__(state, form)
        self.fills = fills

    def update(self) -> None:
        """The bodies' velocities into the form, then assemble."""
        for function, st in self.fills:
            function.x.array[:] = st.v
        super().update()


def interface_terms(interfaces, states: dict[str, BodyState], tests: dict, emaps,
                    zeta: float, filtered: bool = False) -> list[ExternalTerm]:
    """Both sides of every small-sliding interface, damped at ``zeta`` (0: as implicit).

    Args:
        interfaces: The model's interfaces (:class:`~forming.contact.interface.InterfaceTerm`).
        states: The explicit state of every body, by name.
        tests: The bodies' test functions, by name.
        emaps: The scene mesh's entity maps (or None).
        zeta: Fraction of critical damping of the nodes' normal approach.
        filtered: The damped interfaces' friction reads their filtered pressure
            (``explicit.friction_filter``; the solver advances the filters).
    """
    out: list[ExternalTerm] = []
    for itf in interfaces:
        if zeta <= 0:
            out += [ExternalTerm(states[name], fem.form(r, entity_maps=emaps))
                    for name, r in itf.residuals(tests).items()]
            continue
        first, second = (states[b] for b in itf.bodies)
        damping = itf.damping(zeta, (first.m_phys, second.m_phys), filtered)
        fills = list(zip(damping.velocities, (first, second), strict=True))
        out += [InterfaceSide(states[name], fem.form(r, entity_maps=emaps), fills)
                for name, r in itf.damped_residuals(tests, damping).items()]
    return out


def sliding_damping(sliding, states: dict[str, BodyState], zeta: float):
    """A sliding interface's normal damping at ``zeta`` of critical (None: ``zeta`` 0).

    Args:
        sliding: The interface (:class:`~forming.contact.sliding.SlidingTerm`).
        states: The explicit state of every body, by name.
        zeta: Fraction of critical damping (of the slave's physical nodal mass).
    """
    if zeta <= 0:
        return None
    master, slave = (states[b] for b in sliding.bodies)
    return sliding.damping(zeta, slave.m_phys, slave.v, master.v)


class ToolTerm:
    """A tool contact on one body, evaluated node by node at the rank's owned nodes.

    Args:
        state: The body's explicit state.
        contact: The tool contact (a :class:`~forming.contact.terms.ContactTerm`).
        damping: Fraction of critical damping of each node's normal approach on the
            penalty spring (0: none).
    """

    def __init__(self, state: BodyState, contact, damping: float = 0.0):
        self.state = state
        self.contact = contact
        self.nodal = contact.nodal()
        self.dofs = self.nodal.dofs
        self._zeta = damping
        self.damping = self._damping()  # [MPa s/mm] per node
        self._offset = contact.tool_offset()  # at the last update

    def _damping(self) -> np.ndarray | None:
        """Each node's normal damping for its area (0 where it has none); None: undamped."""
        if self._zeta <= 0:
            return None
        nodal = self.nodal
        mass = self.state.m_phys.reshape(-1, 3)[nodal.nodes, 0]
        touching = nodal.area > 0.0
        areal = np.divide(mass, nodal.area, out=np.zeros_like(mass), where=touching)
        return np.where(touching, critical_damping(self._zeta, nodal.penalty, areal), 0.0)

    def stale(self) -> bool:
        """True when erosion on this rank changed the surface the tool meets (local)."""
        return self.contact.exposed is not None and self.contact.exposed.stale()

    def expose(self) -> None:
        """Take the surface erosion has uncovered (collective; nothing without erosion).

        A node that joins the surface starts without friction history: its slip is
        measured from where it is.
        """
        exposed = self.contact.exposed
        if exposed is None:
            return
        nodal = self.nodal
        area = exposed.areas(nodal.nodes)
        joined = (nodal.area <= 0.0) & (area > 0.0)
        nodal.area[:] = area
        if nodal.friction > 0.0 and joined.any():
            nodal.lam_t[joined] = 0.0
            nodal.u_prev[joined] = self.state.body.u.x.array.reshape(-1, 3)[nodal.nodes[joined]]
        self.damping = self._damping()

    def hold(self) -> None:
        """An interval starts (or a restart): take the tool's position now as its last one.

        The surface the tool meets becomes what erosion has left (collective).
        """
        self._offset = self.contact.tool_offset()
        self.expose()

    def update(self, dt: float | None = None) -> None:
        """Evaluate the contact and add its residual to the body's (owned entries).

        Args:
            dt: The increment just taken (the tool's and the nodes' velocities over it
                damp the normal approach); None: no damping (the state at rest).
        """
        offset = self.contact.tool_offset()
        rate = None
        if self.damping is not None and dt:
            rate = (self.damping, self.state.v, (offset - self._offset) / dt)
        self._offset = offset
        self.nodal.add_residual(self.state.u_arr, offset, self.state.f_all_arr,
                                rate)

    def work_on_body(self, du: np.ndarray) -> float:
        """Work of the contact forces on the body over the increment [N mm] (this rank).

        Args:
            du: The body's displacement increment (owned entries).
        """
        r = self.nodal.r_old + self.nodal.r
        return -0.5 * float(r.ravel() @ du[self.dofs])

    def commit(self) -> None:
        """Accept the increment's friction history."""
        self.nodal.commit(self.state.u_arr, self.contact.tool_offset())

    def residual_vector(self) -> np.ndarray:
        """The last residual as an array of the body's vector (a snapshot)."""
        full = np.zeros_like(self.state.body.u.x.array)
        full[self.dofs] = self.nodal.r.ravel()
        return full

    def set_residual_vector(self, full: np.ndarray) -> None:
        """Return the last residual to a snapshot."""
        self.nodal.r[:] = full[self.dofs].reshape(-1, 3)


class _Part:
    """One body's share of a constraint assembled outside the forms (see OutsideForms)."""

    def __init__(self, state: BodyState):
        self.state = state
        self.vec = fem.Function(state.body.V)
        self.r_old = np.zeros(state.n_owned)

    def update(self) -> None:
        """Nothing: :meth:`OutsideForms.update` fills every part at once."""

    @property
    def r_new(self) -> np.ndarray:
        """The part's owned entries as last assembled."""
        return self.vec.x.array[: self.state.n_owned]


class OutsideForms:
    """A constraint assembled by global index (finite sliding), for the explicit solver.

    One global vector in the layout of the implicit solver, split into a part per body
    after every assembly. The constraint searches its pairs afresh at each output
    interval (:meth:`start_interval`), not at each increment.

    Args:
        term: The constraint (``add_residual(vec, damping)`` with global indices).
        layout: The model's dof layout.
        states: The explicit state of the bodies it acts on.
        damping: Its normal damping (:meth:`SlidingTerm.damping`), or None.
    """

    def __init__(self, term, layout, states: list[BodyState], damping=None):
        from petsc4py import PETSc

        self.term = term
        self.damping = damping
        term.search_on_load(False)
        self.parts = [_Part(st) for st in states]
        comm = states[0].body.mesh.comm
        self._vec = PETSc.Vec().createMPI((layout.local_size, PETSc.DECIDE), comm=comm)
        self._slices = [slice(layout.local_offset(st.name),
                              layout.local_offset(st.name) + st.n_owned) for st in states]

    def start_interval(self) -> None:
        """An output interval begins: a full search at the next assembly."""
        self.term.repair()

    def update(self) -> None:
        """Assemble the constraint's residual and hand each body its part."""
        self._vec.zeroEntries()
        self.term.add_residual(self._vec, self.damping, penalty_stick=True)
        values = self._vec.getArray(readonly=True)
        for part, sl in zip(self.parts, self._slices, strict=True):
            part.r_old[:] = part.r_new
            part.vec.x.array[: part.state.n_owned] = values[sl]
            part.vec.x.scatter_forward()


class PressureFilters:
    """The filtered pressures of the interfaces whose friction reads them (explicit).

    Each is a low-pass filter of time constant ``tau`` of the interface's nodal
    pressure, advanced once per increment; its values are part of the solver's state.
    """

    def __init__(self, interfaces, tau: float):
        self.interfaces = [i for i in interfaces if i.filtered_pressure is not None]
        self.tau = tau

    def advance(self, dt: float) -> None:
        """One increment of ``dt`` [s]."""
        for itf in self.interfaces:
            itf.filter_pressure(dt / (self.tau + dt))

    def state(self) -> list[np.ndarray]:
        """Copies of the filtered pressures."""
        return [i.filtered_pressure.x.array.copy() for i in self.interfaces]

    def set_state(self, arrays: list[np.ndarray]) -> None:
        """Back to :meth:`state`'s values."""
        for itf, arr in zip(self.interfaces, arrays, strict=True):
            itf.filtered_pressure.x.array[:] = arr

    def layout(self) -> list:
        """Where each filtered pressure lives (its interface's first body's mesh)."""
        return [i.first.domain.layout(i.filtered_pressure.function_space)
                for i in self.interfaces]
