"""Explicit dynamics: central differences with a lumped mass, over the same model forms.

The solver advances the same :class:`~forming.model.Model` as the implicit solver: the
internal forces are the bodies' residual forms (the same UFL, the same point kernels),
contact and interface tractions are the same terms with their multipliers left at zero
(pure penalty), and history (plastic strain, friction) is committed after every time
increment. One call of :meth:`ExplicitSolver.solve` integrates one output interval of
the load programme, so the step lifecycle of :func:`forming.run.simulate` (advance,
predict, solve, accept or roll back, output) is shared with the implicit solver.

Within an increment nothing is assembled through forms where compiled loops exist: a
solid on hexahedra computes its internal forces element by element
(:class:`~forming.bodies.hexforce.HexInternalForce`, full, reduced or thickness
integration), and a tool contact node by node (:class:`~forming.contact.nodal.NodalContact`);
fabric skins, interfaces and distributed loads are assembled from their forms. Works are
summed over ranks once per output interval (:class:`~forming.solver.ledger.EnergyLedger`).

The load parameter ``s(tau)`` follows a smooth step over ``loading_time`` seconds (no
velocity or acceleration at the ends) or a ramp: docs/theory.md, section 12.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat, signals  # noqa: F401
from forming.bodies.hexforce import loop_metrics, loop_timing, smallest_corner_det
from forming.contact.selfcontact import SelfContactTerm
from forming.errors import InputError, KernelFailure
from forming.model import Model
from forming.solver import leapfrog, lumped
from forming.solver.base import StepResult
from forming.solver.ledger import EnergyLedger, run_warnings
from forming.solver.lumped import BodyState, ExternalTerm, OutsideForms, ToolTerm, body_density
from forming.solver.options import ExplicitOptions
from forming.solver.stepping import StepControl
from forming.solver.timestep import StableStep
from forming.vectors import assembled

log = logging.getLogger(__name__)

_CHECK_EVERY = 16  # increments between collective checks (stop request, time step)
MASS_ADDED_LIMIT = 0.05  # added mass above which a run is flagged (fraction of the mass)


class ExplicitSolver:
    """Central-difference integration of a model over output intervals.

    Args:
        model: The model (the same object the implicit solver would take).
        options: Explicit settings.
    """

    kind = "explicit"
    work_name = "time increments"
    work_column = "time_increments"
    retries_on_failure = False  # an unstable explicit run does not recover by cutting back

    def __init__(self, model: Model, options: ExplicitOptions | None = None):
        if model.stabilisation is not None:
            raise InputError("scene.stabilisation", "viscous stabilisation is for implicit "
                             "runs; an explicit run damps with explicit.damping")
        if not model.penalty_only:
            raise InputError("model", "an explicit run enforces contact by the penalty "
                             "alone: build its model with Model(scene, penalty_only=True)")
        self.model = model
        self.options = opts = options or ExplicitOptions()
        self.comm = model.comm
        bcs = {n: [bc for bc, b in zip(model.dirichlet.bcs, model.dirichlet.bc_bodies,
                                       strict=True) if b == n] for n in model.names}
        self.states = [BodyState(n, model.bodies[n], bcs[n]) for n in model.names]
        if unknown := set(opts.damped_bodies) - set(model.names):
            raise InputError("explicit.damped_bodies", f"names no body of the scene: "
                             f"{sorted(unknown)} (its bodies: {', '.join(model.names)})")
        self._alpha = {n: opts.damping if not opts.damped_bodies or n in opts.damped_bodies
                       else 0.0 for n in model.names}
        by_name = {st.name: st for st in self.states}
        tests = model.test_functions()
        emaps = model.entity_maps or None
        # internal forces: element loops where the body has them, else its form
        self._loops = {st.name: st.body.explicit_internal_force(
            opts.integration, opts.hourglass, body_density(st.body), opts.hourglass_plastic,
            opts.distortion_control, opts.adaptive_strain) for st in self.states}
        self._loop_list = [loop for loop in self._loops.values() if loop is not None]
        self._internal = {n: fem.form(b.residual(tests[n]), entity_maps=emaps)
                          for n, b in model.bodies.items() if self._loops[n] is None}
        # tool contacts node by node: tool work and friction energy
        zeta_c = opts.contact_damping  # the normal approach of contacts, damped
        self._tools = [ToolTerm(by_name[c.spec.body], c, zeta_c) for c in model.contacts]
        self._sides = lumped.interface_terms(model.interfaces, by_name, tests, emaps, zeta_c,
                                             opts.friction_filter > 0 and zeta_c > 0)
        self._filters = lumped.PressureFilters(model.interfaces, opts.friction_filter)
        # distributed loads: external forces that are neither contact nor interface
        self._loads = [ExternalTerm(by_name[tr.body], fem.form(
            -ufl.dot(const, tests[tr.body]) * ds, entity_maps=emaps))
            for tr, const, ds in model.tractions]
        # finite sliding: assembled by global index, split per body after each assembly
        self._outside = [OutsideForms(sl, model.layout, [by_name[b] for b in sl.bodies],
                                      lumped.sliding_damping(sl, by_name, zeta_c))
                         for sl in model.sliding]
        self._sides += [part for o in self._outside for part in o.parts]
        # surfaces in contact with themselves (folding walls): penalty at every increment
        self._selves = [SelfContactTerm(by_name[sc.spec.body], sc, lambda: self.dt)
                        for sc in model.self_contacts]
        self._sides += self._selves
        # damping of the bodies' stiffest modes (fabric fibres), at the half-step velocities
        self._viscous = (lumped.viscous_terms(self.states, tests, emaps)
                         if opts.fibre_damping > 0 else [])
        self._terms = [*self._sides, *self._loads, *self._viscous]  # assembled from forms
        # what the solver commits itself at every increment (not through the model)
        self._own = {id(loop.body) for loop in self._loop_list}
        self._own |= {id(t.contact) for t in self._tools}
        # recorded reactions: the residual at a face's prescribed dofs, f_all . w
        self._reactions = [(key, by_name[name], w.x.array[: by_name[name].n_owned])
                           for key, (name, w) in model.dirichlet.reaction_weights.items()]
        self._bound = StableStep(model, self.states, opts, max(
            opts.fibre_damping if self._viscous else 0.0,
            zeta_c if self._tools or self._outside or model.interfaces else 0.0))
        self.mass_added_fraction = self._bound.scale_masses()
        self.tau = 0.0
        self.time_steps = 0
        self.steps_run = 0  # increments integrated by this run (not by the one it resumed)
        self.assembly_seconds = 0.0
        self.integration_seconds = 0.0  # wall time in solve(), rank 0's
        self.ledger = EnergyLedger()
        self._s_end = 0.0
        self._impulse: dict[str, np.ndarray] = {}
        self._reaction_impulse: dict[str, float] = {}
        self._tau_start = 0.0
        # per body: u, f_int, f_all and v at the increment's start, its displacement
        self._old = [(np.zeros(st.body.u.x.array.size), np.zeros(st.n_owned),
                      np.zeros(st.n_owned), np.zeros(st.v.size), np.zeros(st.n_owned))
                     for st in self.states]
        self.dt = math.inf  # no time step yet: a self-contact's penalty is 0 at rest
        self._failure = ""  # a point kernel's failure on this rank, until the ranks check
        self._assemble_forces()  # forces at rest (e.g. a preload) give a_0
        if failure := self.comm.allreduce(self._failure, op=MPI.MAX):
            raise KernelFailure(failure)
        self.dt = self._dt_ref = self._time_step()
        self._omega2_ref = self._omega2_now = self._omega2()
        self._s_bound = 0.0  # load parameter of the last Gershgorin bound
        for st in self.states:
            self._accelerate(st)
        log.info("explicit: stable time step %.3g s, about %d increments, mass added %.3g%%, %s"
                 " integration of hexahedral solids", self.dt, int(opts.loading_time / self.dt)
                 + 1, 100 * self.mass_added_fraction, opts.integration)

    def _time_step(self) -> float:
        """The stable time step now (collective); the damping time follows it."""
        dt = self._bound.time_step()
        for term in self._viscous:  # the highest mode damped at fibre_damping of critical
            term.beta.value = self.options.fibre_damping * self._bound.critical
        return dt

    def _local_omega2(self) -> float:
        """The largest element frequency bound of this rank's element loops [1/s^2]."""
        return max((loop.omega2 for loop in self._loop_list), default=0.0)

    def _omega2(self) -> float:
        """The largest element frequency bound over all ranks (collective)."""
        return self.comm.allreduce(self._local_omega2(), op=MPI.MAX)

    def _follow_stiffening(self, omega2: float) -> None:
        """Shorten the time step as the stiffest element stiffens (crushing, compression).

        Between two Gershgorin bounds (``bound_every``), the element loops track
        the Flanagan-Belytschko frequency bound of every element in its current shape;
        the step shrinks with the square root of its growth since the last bound.
        """
        if omega2 > self._omega2_ref > 0:
            self.dt = min(self.dt, self._dt_ref * math.sqrt(self._omega2_ref / omega2))

    # -- one increment ----------------------------------------------------------------------
    def _assemble_forces(self, dt: float | None = None) -> None:
        """Every force at the current state (``dt``: the increment that led here)."""
        t0 = time.perf_counter()
        for st in self.states:
            loop = self._loops[st.name]
            try:
                if loop is not None:
                    loop.forces(st.f_int.x)
                else:
                    st.body.update_material(want_tangent=False)
            except KernelFailure as exc:  # this rank's alone: the next check stops all
                self._failure = self._failure or f"point kernel failed: {exc}"
            if loop is None:  # (collective: after a failure too, with the last stresses)
                assembled(self._internal[st.name], st.f_int)
            st.f_all_arr[:] = st.f_int_arr
        for outside in self._outside:
            outside.update()
        for term in self._terms:
            term.update()
            term.state.f_all_arr[:] += term.vec.x.array
        if self._tools:
            for tool in self._tools:
                tool.update(dt)
            for st in self.states:  # tool residuals went into owned entries
                st.f_all.x.scatter_forward()
        self.assembly_seconds += time.perf_counter() - t0

    def _accelerate(self, st: BodyState) -> None:
        """Acceleration a = -R / m - alpha v, zero where the motion is prescribed."""
        leapfrog.accelerate(st.f_all_arr, st.m, st.v, self._alpha[st.name], st.fixed, st.a)

    def _increment(self, dt: float) -> None:
        """Advance by ``dt``: velocity, displacement, load, forces, acceleration, history."""
        model = self.model
        for st, (u0, f0, r0, v0, _du) in zip(self.states, self._old, strict=True):
            # leapfrog: v(n+1/2) = v(n-1/2) + dt a(n); the first half step from rest
            leapfrog.advance(st.u_arr, st.v, st.a, st.f_int_arr, st.f_all_arr, u0, f0, r0,
                             v0, st.n_owned, dt if self.time_steps else 0.5 * dt, dt)
        tool_old = [t.contact.tool_offset() for t in self._tools]
        self.tau += dt
        model.set_load(self.options.load(self.tau))
        for st, (u0, *_rest) in zip(self.states, self._old, strict=True):
            for bc in st.bcs:
                bc.set(st.u_arr)
            leapfrog.prescribed_velocity(st.u_arr, u0, st.v, st.fixed_dofs, dt)
        self._assemble_forces(dt)
        self._account(dt, tool_old)
        for st in self.states:
            self._accelerate(st)
        for tool in self._tools:
            tool.commit()
        for loop in self._loop_list:
            loop.commit()
        model.commit(exclude=self._own)
        self._filters.advance(dt)
        self.time_steps += 1
        self.steps_run += 1

    def _account(self, dt: float, tool_old: list[np.ndarray]) -> None:
        """This rank's works over the increment (trapezoidal rule), tool impulses."""
        w_int = w_ext = w_damp = w_visc = on_bodies = tools = 0.0
        du = {}
        for st, (u0, f0, r0, v0, d) in zip(self.states, self._old, strict=True):
            # all external forces on the free dofs do R = f_int - f_ext; at prescribed
            # dofs the support does the work that changes their kinetic energy; the mass
            # damping's force alpha m v did work on the free ones
            body_int, body_ext, body_damp = leapfrog.works(
                st.u_arr, u0, st.f_int_arr, f0, st.f_all_arr, r0, st.fixed,
                st.m, st.v, v0, self._alpha[st.name], st.n_owned, d)
            du[st.name] = d
            w_int += body_int
            w_ext += body_ext
            w_damp += body_damp
        for term in self._sides:
            on_bodies -= 0.5 * float((term.r_old + term.r_new) @ du[term.state.name])
        for term in self._viscous:  # dissipated, and in R: -R . d is short of it
            w_visc += 0.5 * float((term.r_old + term.r_new) @ du[term.state.name])
        for tool, off0 in zip(self._tools, tool_old, strict=True):
            on_bodies += tool.work_on_body(du[tool.state.name])
            force = tool.nodal.force_on_tool()  # this rank's share
            tools -= float(force @ (tool.contact.tool_offset() - off0))
            self._impulse[tool.contact.name] += force * dt
        for key, st, w in self._reactions:
            self._reaction_impulse[key] += dt * float(st.f_all_arr[: st.n_owned] @ w)
        # what the tools put in, less what reached the nodes, went into friction (and the
        # contacts' penalty springs); -R . d over the free dofs is the kinetic energy gained
        # plus the mass damping's work (not in R): the damping goes to its ledger only
        self.ledger.add(internal=w_int, external=w_ext + w_int + w_visc - on_bodies + tools,
                        friction=tools - on_bodies, damping=w_damp + w_visc)

    def _kinetic(self) -> float:
        """Kinetic energy of this rank's nodes: v(n) = v(n-1/2) + dt/2 a(n)."""
        ke = 0.0
        for st in self.states:
            n = st.n_owned
            v = st.v[:n] + 0.5 * self.dt * st.a[:n]
            ke += 0.5 * float(st.m[:n] @ v**2)
        return ke

    def _push(self) -> None:
        """Hand the element loops' and nodal contacts' history to the model's objects."""
        for loop in self._loop_list:
            loop.push()
        for tool in self._tools:
            tool.contact.push_nodal(tool.nodal)

    # -- step lifecycle ---------------------------------------------------------------------
    def step_control(self, requested: StepControl) -> StepControl:
        """Output intervals of fixed size.

        ``output_interval``, else the job's largest load step, at most 0.02; the job's
        stops are kept.
        """
        size = self.options.output_interval or min(requested.max, 0.02)
        return StepControl(initial=size, max=size, min=size, stops=requested.stops)

    def advance(self, t_old: float, t_new: float, dt_old: float) -> None:
        """Start the interval to load parameter ``t_new``; the increments walk the load."""
        del t_old, dt_old
        self._s_end = t_new
        self._impulse = {t.contact.name: np.zeros(3) for t in self._tools}
        self._reaction_impulse = {key: 0.0 for key, _st, _w in self._reactions}
        self._tau_start = self.tau
        self.model.set_load(self.options.load(self.tau))
        for tool in self._tools:  # surface-mesh tools: pair nodes with facets again
            tool.nodal.repair()
            tool.hold()

    def solve(self) -> StepResult:
        """Integrate in time until the load parameter reaches the interval's end."""
        t0 = time.perf_counter()
        tau_end = self.options.time_of(self._s_end)
        n0 = self.time_steps
        reason = self._failure = ""
        ok = True
        try:
            s_start = self.options.load(self.tau)
            if self.time_steps and s_start >= self._s_bound + self.options.bound_every - 1e-9:
                # the Gershgorin bound reads the body's plastic state, which the last
                # interval's end (or a restore) handed over; the constructor's is the first
                self.dt = self._dt_ref = self._time_step()
                self._omega2_ref, self._s_bound = self._omega2_now, s_start
            for outside in self._outside:
                outside.start_interval()
            while self.tau < tau_end * (1 - 1e-12):
                n_left = math.ceil((tau_end - self.tau) / self.dt - 1e-9)
                dt = (tau_end - self.tau) / max(n_left, 1)
                self._increment(dt)
                if self.time_steps % _CHECK_EVERY:
                    continue
                # collective, so that every rank stops at the same increment
                finite = all(np.all(np.isfinite(st.v)) for st in self.states)
                local = np.array([4.0 * bool(self._failure) + 2.0 * (not finite)
                                  + (signals.requested() is not None), self._local_omega2(),
                                  any(t.stale() for t in self._tools)])
                both = np.empty(3)
                self.comm.Allreduce(local, both, op=MPI.MAX)
                code, omega2, eroded = both
                self._follow_stiffening(omega2)
                for tool in self._tools if eroded else ():  # erosion uncovered new faces
                    tool.expose()
                if code:
                    ok = False
                    reason = (self.comm.allreduce(self._failure, op=MPI.MAX) if code >= 4
                              else "velocities not finite (unstable time step)" if code >= 2
                              else "interrupted")
                    break
            failure = self.comm.allreduce(self._failure, op=MPI.MAX)  # since the last check
            if ok and failure:
                ok, reason = False, failure
            if ok and not all(np.all(np.isfinite(st.v)) for st in self.states):
                ok, reason = False, "velocities not finite (unstable time step)"
        except KernelFailure as exc:
            ok, reason = False, f"point kernel failed: {exc}"
        ok = self.comm.allreduce(ok, op=MPI.LAND)
        if ok:
            self._push()
            self._omega2_now = self._omega2()  # the stiffest element at the interval's end
            artificial = sum(loop.hourglass_energy for loop in self._loop_list)
            reason = self.ledger.close_interval(self.comm, self._kinetic(), artificial,
                                                self._s_end)
            for v in self._impulse.values():
                self.comm.Allreduce(MPI.IN_PLACE, v, op=MPI.SUM)
        elif not reason:
            reason = "failed on another rank"
        seconds = time.perf_counter() - t0
        self.integration_seconds += seconds
        return StepResult(ok and not reason, self.time_steps - n0, [], reason, seconds)

    def accept(self, force_scale: float) -> None:
        """Nothing to carry over: the state lives in the solver's vectors."""
        del force_scale

    def snapshot(self) -> tuple:
        """Velocities, accelerations, force vectors, time, energies and counters."""
        return ([(st.v.copy(), st.a.copy(), st.f_int.x.array.copy(),
                  st.f_all.x.array.copy()) for st in self.states],
                [t.vec.x.array.copy() for t in self._terms],
                [t.residual_vector() for t in self._tools],
                [loop.state() for loop in self._loop_list],
                self.tau, self.ledger.state(), self.time_steps, self.dt,
                [self._dt_ref, self._s_bound], self._omega2_ref, self._omega2_now,
                [t.pair_state_vector() for t in self._selves], self._filters.state())

    def restore(self, snap: tuple) -> None:
        """Return velocities, energies and time to a snapshot; history from the model."""
        (states, terms, tools, loops, self.tau, ledger, self.time_steps, self.dt, ref,
         self._omega2_ref, self._omega2_now, pair_states, *filters) = snap
        self._filters.set_state(filters[0] if filters else self._filters.state())
        # (a checkpoint written before bound_every kept the step alone: bound at once)
        self._dt_ref, self._s_bound = ref if isinstance(ref, list | tuple) else (ref, -1.0)
        for t, arr in zip(self._selves, pair_states, strict=True):
            t.set_pair_state_vector(arr)
        self.ledger.set_state(ledger)
        for st, (v, a, fi, fa) in zip(self.states, states, strict=True):
            st.v[:], st.a[:] = v, a
            st.f_int.x.array[:], st.f_all.x.array[:] = fi, fa
        for t, vec in zip(self._terms, terms, strict=True):
            t.vec.x.array[:] = vec
        for t, vec in zip(self._tools, tools, strict=True):
            t.set_residual_vector(vec)
            t.contact.pull_nodal(t.nodal)
        for loop, state in zip(self._loop_list, loops, strict=True):
            loop.pull()
            loop.set_state(state)

    def snapshot_layout(self) -> tuple:
        """Velocities, accelerations and force vectors are per body; the rest is global."""
        def on(st: BodyState):
            return st.body.domain.layout(st.body.V)

        return ([(on(st),) * 4 for st in self.states], [on(t.state) for t in self._terms],
                [on(t.state) for t in self._tools],
                [loop.state_layout() for loop in self._loop_list],
                None, None, None, None, None, None, None,
                [on(t.state) for t in self._selves], self._filters.layout())

    # -- reporting --------------------------------------------------------------------------
    def balance(self) -> float:
        """Energy balance: kinetic + internal + friction + damping - external work [N mm]."""
        return self.ledger.balance()

    def tool_force(self, contact) -> np.ndarray:
        """Mean force on the tool over the output interval (impulse over time).

        A penalty contact rings, so the force at an instant scatters; as Abaqus/Explicit's
        anti-aliasing filter, the mean over the interval (at the start: the current force).
        """
        span = self.tau - self._tau_start
        if span > 0 and contact.name in self._impulse:
            return self._impulse[contact.name] / span
        return contact.force()

    def reaction(self, key: str) -> float:
        """Mean static reaction (prescribed dofs' residual, no inertia) over the interval."""
        span = self.tau - self._tau_start
        if span > 0 and key in self._reaction_impulse:
            return self.comm.allreduce(self._reaction_impulse[key], op=MPI.SUM) / span
        return self.model.dirichlet.reaction(key)

    def history_columns(self, result: StepResult) -> dict[str, float]:
        """Time increments of the interval, time, time step and the energy ledger [N mm]."""
        out = {"time_increments": result.work, "time_s": self.tau, "time_step_s": self.dt,
               **self.ledger.columns()}
        for sc in self.model.self_contacts:  # at the last increment
            out[f"self_contact_{sc.spec.body}_pairs"] = float(sc.pairs)
            out[f"self_contact_{sc.spec.body}_penetration_mm"] = sc.penetration
        return out

    def metrics(self) -> dict[str, float | bool]:
        """Figures every explicit run reports (``summary.json`` metrics)."""
        led, selves = self.ledger, self.model.self_contacts
        return {"kinetic_to_internal_max": led.ke_ie_max,
                "quasi_static": led.ke_ie_max <= self.options.quasi_static_limit,
                "hourglass_energy_fraction": led.hg_ie_max,
                **loop_metrics(self._loop_list, self.comm),
                "mass_added_fraction": self.mass_added_fraction,
                "energy_balance_error_rel": led.balance_error(),
                } | ({"self_contact_penetration_max_mm": max(sc.deepest for sc in selves)}
                     if selves else {})

    def timing(self) -> dict[str, float]:
        """Figures for ``summary.json`` timing.

        ``us_per_element_increment``: wall time of the time integration (the intervals'
        solves) per element of every body and per increment this run integrated [us].
        """
        n_el = self.comm.allreduce(sum(st.body.n_local_cells for st in self.states))
        out = {"time_steps": self.time_steps, "stable_time_step_s": self.dt,
               "loading_time_s": self.options.loading_time,
               "assembly_s": self.comm.allreduce(self.assembly_seconds) / self.comm.size,
               "integration_s": self.integration_seconds, "elements": n_el}
        out |= self.model.search_timing() | loop_timing(self._loop_list, self.comm)
        if self.steps_run:
            out["us_per_element_increment"] = 1e6 * self.integration_seconds / self.steps_run / n_el
        return out

    def parameters(self) -> dict:
        """The explicit settings the run used."""
        return {"explicit": asdict(self.options)}

    def validity(self) -> dict[str, bool]:
        """Quasi-static, little added mass, little hourglass energy, no folded element."""
        led, opts = self.ledger, self.options
        return {"quasi_static": led.ke_ie_max <= opts.quasi_static_limit,
                "mass_added_below_limit": self.mass_added_fraction <= MASS_ADDED_LIMIT,
                "hourglass_below_limit": led.hg_ie_max <= opts.hourglass_limit,
                "elements_not_folded": smallest_corner_det(self._loop_list) > 0.0}

    def warnings(self) -> list[str]:
        """Not quasi-static, much added mass, hourglassing, one-point crushing."""
        return run_warnings(self.ledger, self.options, self.mass_added_fraction, MASS_ADDED_LIMIT,
                            any(loop.crushes_at_one_point for loop in self._loop_list))

    def close(self) -> None:
        """Nothing: no PETSc solver (the element loops and contacts are its own)."""
