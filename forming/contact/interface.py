"""Contact between two bodies over the facets they share: skins on a core.

Small sliding, node to node: the two bodies are meshed conformingly, so each interface
node of one body starts where a node of the other starts. The terms are integrated on
the scene mesh's interior facets with the nodal rule (``dS``: the vertex rule, or the
Gauss-Lobatto rule at a quadratic face's 9 nodes; "+" = the first body,
whose outward normal, rotated with its deformation, is the contact normal; "-" = the
other body). Gap, pressure and tangential traction therefore live at the interface
nodes, and the multipliers are functions of the first body's mesh, of the higher of
the two bodies' degrees. Normal contact (and a
bonded tie) is an augmented Lagrangian as for tools (:mod:`forming.contact.terms`):
fixed multipliers within a Newton solve, Uzawa updates between solves. Friction is a
Coulomb return mapping on the slip increment of the step with a penalty stick of
elastic slip (docs/theory.md, section 11); its elastic slip is history, updated at
commit, and the stick traction is ``mu p`` times its fraction of the elastic-slip limit.
Explicit runs damp the nodes' normal approach (:meth:`InterfaceTerm.damped_residuals`).
Nodal values of the tractions come from assembling them against the test function
and dividing by the nodal area (the nodal rule makes this exact where the adjacent
facets agree, and an area average where the deformed normal jumps between facets).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem, la  # noqa: I001
from mpi4py import MPI

from forming.contact.laws import (
    coulomb_return,
    normal_pressure,
    smoothed_pressure,
    tangent_projector,
)
from forming.contact.terms import surface_edge_min
from forming.errors import InputError
from forming.history import ForceSampler, interface_columns
from forming.log import collective_warning
from forming.scene import Interface

log = logging.getLogger(__name__)


def interface_entities(md, first, second, region: str) -> np.ndarray:
    """Interior-facet integration entities of ``region``, ``first``'s cell in each row first.

    Args:
        md: The scene mesh data.
        first: Domain (:class:`~forming.domain.BodyDomain`) of the "+" body.
        second: Domain of the "-" body.
        region: Surface group of the shared facets.

    Returns:
        Rows (cell, local facet, cell, local facet) on the scene mesh, flattened.

    Raises:
        InputError: A facet of the region is not shared by the two bodies.
    """
    msh = md.mesh
    facets = md.facets(region)
    ent = fem.compute_integration_domains(fem.IntegralType.interior_facet, msh.topology,
                                          facets.astype(np.int32)).reshape(-1, 4)
    n_cells = msh.topology.index_map(3).size_local + msh.topology.index_map(3).num_ghosts
    in_first = np.zeros(n_cells, dtype=bool)
    in_first[first.parent_cells] = True
    in_second = np.zeros(n_cells, dtype=bool)
    in_second[second.parent_cells] = True
    flip = ~in_first[ent[:, 0]]
    ent[flip] = ent[flip][:, [2, 3, 0, 1]]
    bad = int(np.count_nonzero(~(in_first[ent[:, 0]] & in_second[ent[:, 2]])))
    n_rows = msh.comm.allreduce(ent.shape[0], op=MPI.SUM)
    if msh.comm.allreduce(bad, op=MPI.SUM) or n_rows == 0:
        raise InputError("interface.region",
                         f"{region!r} must consist of interior facets shared by the two "
                         f"bodies ({n_rows} facets found, "
                         f"{msh.comm.allreduce(bad, op=MPI.SUM)} not shared)")
    return ent.ravel()


@dataclass(frozen=True)
class InterfaceDamping:
    """What the damped traction of an interface reads (explicit runs).

    Attributes:
        zeta: Fraction of critical damping of each node pair's normal approach.
        velocities: The first and the second body's velocities (filled by the solver
            before each assembly).
        areal: The first and the second body's nodal masses over their interface areas
            [t/mm^2] (per dof; zero off the interface).
    """

    zeta: float
    velocities: tuple[fem.Function, fem.Function]
    areal: tuple[fem.Function, fem.Function]
    pressure: fem.Function | None = None  # the friction's filtered pressure (None: p)


class InterfaceTerm:
    """Frictional (or bonded) contact between two bodies on their shared facets.

    Args:
        spec: The scene's interface.
        first: The body whose outward normal is the contact normal ("+").
        second: The body on the other side ("-").
        dS: The scene mesh's interior-facet measure restricted to this interface, with
            the nodal rule of ``degree`` (:func:`~forming.contact.terms.nodal_rule`).
        thickness: Smallest extent of the two bodies [mm] (caps the default tolerance).
        degree: Degree of the multipliers: the higher of the two bodies' degrees (a
            quadratic face is tied at all 9 of its nodes, not only at its corners).
    """

    def __init__(self, spec: Interface, first, second, dS: ufl.Measure, thickness: float,
                 degree: int = 1):
        self.spec = spec
        self.name = spec.region
        self.bodies = (spec.body, spec.other)
        self.first = first
        self.second = second
        self._dS = dS
        self._warned: list[str] = []
        parent = first.domain.md.mesh
        self.comm = parent.comm
        self.entity_maps = first.domain.entity_maps + second.domain.entity_maps
        facets = first.domain.facets(spec.region)
        h = surface_edge_min(first.mesh, facets)
        self.edge = h
        self.tolerance = spec.tolerance or 0.01 * min(h, thickness)
        self.penalty = spec.penalty or 10.0 * first.contact_stiffness() / h
        self.friction = spec.friction if spec.kind == "frictional" else 0.0
        self.bonded = spec.kind == "bonded"
        self._eps = fem.Constant(parent, self.penalty)
        msh = first.mesh
        W = fem.functionspace(msh, ("Lagrange", degree))
        Wv = fem.functionspace(msh, ("Lagrange", degree, (3,)))
        self._dofs = fem.locate_dofs_topological(W, 2, facets)
        self._x = W.tabulate_dof_coordinates()
        self._owned = self._dofs[self._dofs < W.dofmap.index_map.size_local]
        self.lam_n = None if self.bonded else fem.Function(W, name="interface_pressure")
        # tangential history: the elastic slip [mm] (frictional) or the traction (bonded)
        self.lam_t = None
        if self.bonded or self.friction > 0.0:
            self.lam_t = fem.Function(Wv, name="interface_traction" if self.bonded
                                      else "interface_elastic_slip")
        u1, u2 = first.u("+"), second.u("-")
        F1 = ufl.Identity(3) + ufl.grad(first.u)("+")
        n0 = ufl.FacetNormal(parent)("+")
        m = ufl.det(F1) * ufl.inv(F1).T * n0
        n = m / ufl.sqrt(ufl.dot(m, m))
        self.normal = n
        jump = u2 - u1
        proj = tangent_projector(n)
        self.slip_total = proj * jump
        self.gap = ufl.dot(jump, n)
        self.pressure = None
        self.shear = None
        if self.bonded:
            traction = self.lam_t("+") - self._eps * jump  # on the second body
        else:
            trial_p = self.lam_n("+") - self._eps * self.gap
            if spec.smoothing > 0.0:
                # smoothed ramp: every node of a conforming interface starts at the kink
                # (gap 0, pressure 0), where Newton can cycle between open and closed
                delta = fem.Constant(parent, spec.smoothing * self.penalty * self.tolerance)
                self._ramp = lambda trial: smoothed_pressure(trial, delta)
            else:
                self._ramp = normal_pressure
            self.pressure = self._ramp(trial_p)
            # the Uzawa update uses the exact (kinked) ramp: its fixed point is exact
            # complementarity, and the smoothing only changes the Newton iterates' force by
            # at most delta / 2 (an equivalent penetration of smoothing / 2 x tolerance);
            # updating with the smoothed ramp drove lam * gap to a constant, slowly
            self._uzawa_pressure = normal_pressure(trial_p)
            self._trial_p = trial_p
            traction = self.pressure * n
        self.u1_prev = fem.Function(first.V)
        self.u2_prev = fem.Function(second.V)
        step_jump = jump - (self.u2_prev("-") - self.u1_prev("+"))
        # elastic slip allowed while sticking (Abaqus' default: 0.5% of the facet edge)
        self.elastic_slip = 0.005 * h
        if self.friction > 0.0:  # a frictionless interface compiles no tangential terms
            # Penalty stick with a stiffness proportional to the pressure, mu p / slip_el:
            # stick and slip then switch at an elastic slip independent of the pressure, and
            # the tangential stiffness vanishes smoothly with it. Every node of a skin laid
            # on a core starts at zero pressure; an augmented stick constraint switched there
            # between stick and slip in arbitrary directions and stalled Newton (hemisphere).
            # The history is the elastic slip (at most elastic_slip long), not the traction:
            # the stick spring follows the pressure at once. With the traction as history a
            # node whose pressure dipped kept the lower traction and rebuilt it by k_t times
            # the slip of each increment: explicit runs lost their friction to this ratchet
            # (the sled's drag fell from 0.5 to 0.01 of the load at a steady normal force).
            increment = proj * step_jump
            self._s_el = coulomb_return(proj * self.lam_t("+") + increment, self.elastic_slip)
            self.shear = -(self.friction / self.elastic_slip) * self.pressure * self._s_el
            traction = traction + self.shear
        self.stabilisation = None
        self._stab = None
        if spec.stabilisation > 0.0 and not self.bonded:
            # a weak spring on the relative motion within the step (Abaqus' contact
            # stabilisation): it gives a skin that lifts off, or a node that opens and
            # closes, some stiffness; its force is reported (stabilisation_force)
            self.stabilisation = fem.Constant(parent, spec.stabilisation * self.penalty)
            self._stab = -self.stabilisation * step_jump
            traction = traction + self._stab
        self.traction = traction
        self.has_spring, self.spring_scale = self.stabilisation is not None, 1.0
        # nodal values: assemble against the test function, divide by the nodal area
        w, wv = ufl.TestFunction(W), ufl.TestFunction(Wv)
        self._area = self._assemble(self._form(w("+") * dS))
        self._area_v = np.repeat(self._area, 3)
        if self.pressure is not None:
            self._p_form = self._form(self._uzawa_pressure * w("+") * dS)
            self._g_form = self._form(self.gap * w("+") * dS)
        if self.lam_t is not None:
            new_t = self.traction if self.bonded else self._s_el
            self._t_form = self._form(ufl.dot(new_t, wv("+")) * dS)
        self._slip_form = self._form(ufl.dot(self.slip_total, wv("+")) * dS)
        self._normal_force = self._form(
            (ufl.dot(self.traction, n) if self.bonded else self.pressure) * dS)
        self._shear_forms = [self._form((proj * self.traction)[i] * dS) for i in range(3)]
        self._stab_form = (None if self.stabilisation is None else
                           self._form(ufl.sqrt(ufl.dot(self._stab, self._stab) + 1e-30) * dS))
        self._p_filtered: fem.Function | None = None  # explicit.friction_filter
        self._p_new = None if self.lam_n is None else np.zeros_like(self.lam_n.x.array)
        self._t_new = None if self.lam_t is None else np.zeros_like(self.lam_t.x.array)

    # -- helpers ------------------------------------------------------------------------
    def _form(self, ufl_form) -> fem.Form:
        return fem.form(ufl_form, entity_maps=self.entity_maps or None)

    def _assemble(self, form: fem.Form) -> np.ndarray:
        """Assembled vector with shared-node contributions summed and ghosts updated."""
        vec = fem.assemble_vector(form)
        vec.scatter_reverse(la.InsertMode.add)
        vec.scatter_forward()
        return vec.array.copy()

    def _nodal(self, form: fem.Form, values_per_node: int) -> np.ndarray:
        area = self._area if values_per_node == 1 else self._area_v
        out = self._assemble(form)
        nz = area > 0
        out[nz] /= area[nz]
        return out

    def _reduce_max(self, values: np.ndarray) -> float:
        local = float(values.max()) if values.size else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    # -- forms ----------------------------------------------------------------------------
    def side_residuals(self, v1, v2) -> tuple[ufl.Form, ufl.Form]:
        """Virtual work of the interface traction on the first and the second body."""
        return (ufl.dot(self.traction, v1("+")) * self._dS,
                -ufl.dot(self.traction, v2("-")) * self._dS)

    def residuals(self, tests: dict) -> dict[str, ufl.Form]:
        """Virtual work of the interface traction on both bodies, by body name."""
        r1, r2 = self.side_residuals(tests[self.spec.body], tests[self.spec.other])
        return {self.spec.body: r1, self.spec.other: r2}

    def damping(self, zeta: float, masses: tuple[np.ndarray, np.ndarray],
                filtered: bool = False) -> InterfaceDamping:
        """Damping of the nodes' relative normal approach at ``zeta`` of critical.

        Each pair of nodes is a two-mass oscillator on the penalty spring: its critical
        damping per area is ``2 sqrt(eps m_r / A)`` with the reduced mass
        ``m_r = m1 m2 / (m1 + m2)`` (about the skin node's on a core).

        Args:
            zeta: Fraction of critical damping.
            masses: The lumped masses of the first and the second body (3 per node) [t].
            filtered: The friction reads the pressure through a low-pass filter
                (:meth:`filter_pressure`), not the pressure of the increment.
        """
        ones = ufl.as_vector([1.0, 1.0, 1.0])
        areal = []
        for body, side, m in ((self.first, "+", masses[0]), (self.second, "-", masses[1])):
            area = self._assemble(self._form(ufl.dot(ones, ufl.TestFunction(body.V)(side))
                                             * self._dS))
            a = fem.Function(body.V)
            on = area > 0
            a.x.array[on] = m[on] / area[on]
            areal.append(a)
        if filtered and self.friction > 0.0 and self._p_filtered is None:
            self._p_filtered = fem.Function(self.lam_n.function_space,
                                            name="interface_filtered_pressure")
        return InterfaceDamping(zeta, (fem.Function(self.first.V),
                                       fem.Function(self.second.V)), tuple(areal),
                                self._p_filtered if filtered else None)

    def filter_pressure(self, weight: float) -> None:
        """Move the filtered pressure towards the nodal pressure now by ``weight``.

        An exponential moving average: ``weight = dt / (tau + dt)`` per increment is a
        low-pass filter of time constant ``tau`` (explicit runs,
        ``explicit.friction_filter``).
        """
        if self._p_filtered is None:
            return
        p = self._nodal(self._p_form, 1)
        d = self._dofs
        arr = self._p_filtered.x.array
        arr[d] += weight * (p[d] - arr[d])
        self._p_filtered.x.scatter_forward()

    @property
    def filtered_pressure(self) -> fem.Function | None:
        """The friction's filtered nodal pressure (explicit runs that filter it), or None."""
        return self._p_filtered

    def damped_residuals(self, tests: dict, damping: InterfaceDamping) -> dict[str, ufl.Form]:
        """As :meth:`residuals`, with a viscous traction on the nodes' approach (explicit).

        A frictional or frictionless interface adds ``-c dg/dt`` to the trial pressure
        where the node penetrates (it never pulls, and it does not push before contact);
        the friction limit stays with the penalty pressure, so the committed friction
        history is the one applied, or, with ``damping.pressure``, with that pressure
        filtered in time. A bonded interface's tie gets ``-c`` times the whole relative
        velocity.
        """
        a1, a2 = damping.areal[0][0], damping.areal[1][0]
        c = 2.0 * damping.zeta * ufl.sqrt(self._eps * a1("+") * a2("-") / (a1("+") + a2("-")))
        rel = damping.velocities[1]("-") - damping.velocities[0]("+")
        if self.bonded:
            traction = self.traction - c * rel
        else:
            rate = ufl.dot(rel, self.normal)
            trial = self._trial_p - ufl.conditional(ufl.lt(self.gap, 0.0), c * rate, 0.0)
            pressure = self._ramp(trial)
            traction = pressure * self.normal
            if self.friction > 0.0:  # the same elastic slip, at the damped pressure
                # or at the filtered one: a stick spring whose stiffness follows a ringing
                # pressure is a parametric oscillator that the ringing feeds
                p_f = pressure if damping.pressure is None else damping.pressure("+")
                traction = traction - (self.friction / self.elastic_slip) * p_f * self._s_el
            if self._stab is not None:
                traction = traction + self._stab
        v1, v2 = tests[self.spec.body], tests[self.spec.other]
        return {self.spec.body: ufl.dot(traction, v1("+")) * self._dS,
                self.spec.other: -ufl.dot(traction, v2("-")) * self._dS}

    def stiffness_estimate(self, tests: dict) -> dict[str, ufl.Form]:
        """Twice the penalty on each side's nodes: the coupling row adds as much again."""
        ones = ufl.as_vector([1.0, 1.0, 1.0])
        w1, w2 = tests[self.spec.body], tests[self.spec.other]
        return {self.spec.body: 2.0 * self._eps * ufl.dot(ones, w1("+")) * self._dS,
                self.spec.other: 2.0 * self._eps * ufl.dot(ones, w2("-")) * self._dS}

    # -- load programme -------------------------------------------------------------------
    def set_load(self, t: float) -> None:
        """Nothing moves with the load parameter: both sides are bodies."""

    # -- augmentation ---------------------------------------------------------------------
    def penetration(self) -> float:
        """Largest nodal penetration of the second body into the first [mm] (0 if none)."""
        if self.pressure is None:
            return 0.0
        g = self._nodal(self._g_form, 1)
        return max(self._reduce_max(-g[self._owned]), 0.0)

    def violation(self) -> float:
        """Largest change of a nodal multiplier over the penalty [mm] (see ContactTerm)."""
        own = self._owned
        worst = 0.0
        if self.lam_n is not None:
            self._p_new = self._nodal(self._p_form, 1)
            worst = self._reduce_max(np.abs(self._p_new[own] - self.lam_n.x.array[own]))
        if self.bonded:  # frictional shear is a penalty with elastic slip: no Uzawa
            self._t_new = self._nodal(self._t_form, 3)
            new = self._t_new.reshape(-1, 3)[own]
            old = self.lam_t.x.array.reshape(-1, 3)[own]
            worst = max(worst, self._reduce_max(np.linalg.norm(new - old, axis=1)))
        return worst / self.penalty

    def track(self) -> None:
        """Nothing to follow: the skin and core nodes stay paired (small sliding)."""

    def augment(self) -> None:
        """Uzawa update: the multipliers become the tractions of :meth:`violation`."""
        d = self._dofs
        if self.lam_n is not None:
            self.lam_n.x.array[d] = self._p_new[d]
            self.lam_n.x.scatter_forward()
        if self.bonded:
            self.lam_t.x.array.reshape(-1, 3)[d] = self._t_new.reshape(-1, 3)[d]
            self.lam_t.x.scatter_forward()

    def commit(self) -> None:
        """Accept the step: the slip of the next step is measured from here."""
        if self.friction > 0.0:
            t = self._nodal(self._t_form, 3)
            d = self._dofs
            self.lam_t.x.array.reshape(-1, 3)[d] = t.reshape(-1, 3)[d]
            self.lam_t.x.scatter_forward()
        self.u1_prev.x.array[:] = self.first.u.x.array
        self.u2_prev.x.array[:] = self.second.u.x.array

    def snapshot(self) -> tuple:
        """Copy of the multipliers and of the slip reference (the last converged state)."""
        return (None if self.lam_n is None else self.lam_n.x.array.copy(),
                None if self.lam_t is None else self.lam_t.x.array.copy(),
                self.u1_prev.x.array.copy(), self.u2_prev.x.array.copy())

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""
        if self.lam_n is not None:
            self.lam_n.x.array[:] = snap[0]
        if self.lam_t is not None:
            self.lam_t.x.array[:] = snap[1]
        self.u1_prev.x.array[:] = snap[2]
        self.u2_prev.x.array[:] = snap[3]

    def snapshot_layout(self) -> tuple:
        """Layouts of the multipliers (on the first body) and of both slip references."""
        first, second = self.first.domain, self.second.domain
        return (None if self.lam_n is None else first.layout(self.lam_n.function_space),
                None if self.lam_t is None else first.layout(self.lam_t.function_space),
                first.layout(self.first.V), second.layout(self.second.V))

    # -- outputs --------------------------------------------------------------------------
    def slip(self) -> tuple[np.ndarray, np.ndarray]:
        """Tangential slip vectors [mm] and reference coordinates of this rank's nodes."""
        s = self._nodal(self._slip_form, 3).reshape(-1, 3)
        return s[self._owned], self._x[self._owned]

    def max_slip(self) -> float:
        """Largest tangential slip over the interface nodes of all ranks [mm]."""
        s, _x = self.slip()
        return self._reduce_max(np.linalg.norm(s, axis=1))

    def normal_force(self) -> float:
        """Total normal (compressive) force across the interface [N]."""
        return self.comm.allreduce(fem.assemble_scalar(self._normal_force), op=MPI.SUM)

    def scale_spring(self, scale: float) -> None:
        """Set the stabilising spring to ``scale`` times its setting (forming.springs)."""
        self.spring_scale = scale
        if self.stabilisation is not None:
            self.stabilisation.value = scale * self.spec.stabilisation * self.penalty

    def stabilisation_force(self) -> float:
        """Integral of the stabilisation traction's magnitude [N] (0 if none)."""
        if self.stabilisation is None:
            return 0.0
        return self.comm.allreduce(fem.assemble_scalar(self._stab_form), op=MPI.SUM)

    def shear_force(self) -> np.ndarray:
        """Total tangential force the first body exerts on the second [N]."""
        return np.array([self.comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                         for f in self._shear_forms])

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """Penetration, largest slip, normal force (and stabilisation force) columns.

        Warns once when the slip exceeds ``slip_warning`` times the facet edge: the
        small-sliding pairing loses accuracy from there.
        """
        del forces  # the interface forces are internal to the model
        names = interface_columns(self.name)
        slip = self.max_slip()
        row = {names["penetration"]: self.penetration(), names["slip"]: slip,
               names["normal_force"]: self.normal_force()}
        if self.stabilisation is not None:
            row[names["stabilisation_force"]] = self.stabilisation_force()
        if slip > self.spec.slip_warning * self.edge and not self._warned:
            msg = (f"interface {self.name}: slip {slip:.3g} mm exceeds "
                   f"{self.spec.slip_warning:.2g} x the facet edge ({self.edge:.3g} mm); the "
                   f"small-sliding pairing loses accuracy from here")
            self._warned.append(msg)
            collective_warning(log, "%s", msg)
        return row

    def warnings(self) -> list[str]:
        """The slip warning, once it was raised."""
        return list(self._warned)
