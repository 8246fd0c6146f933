"""Explicit dynamics: central differences with a lumped mass, over the same model forms.

The solver advances the same :class:`~forming.model.Model` as the implicit solver: the
internal forces are the bodies' residual forms (the same UFL, the same point kernels),
contact and interface tractions are the same terms with their multipliers left at zero
(pure penalty), and history (plastic strain, friction) is committed after every time
increment. One call of :meth:`ExplicitSolver.solve` integrates one output interval of
the load programme, so the step lifecycle of :func:`forming.run.simulate` (advance,
predict, solve, accept or roll back, output) is shared with the implicit solver.

Time and load parameter: the load programme runs over ``loading_time`` seconds with the
load parameter ``s(tau)`` following a smooth step (zero velocity and acceleration at
both ends), or a linear ramp. See docs/theory.md, section 12 ("Explicit dynamics").
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from dolfinx.fem.petsc import assemble_matrix
from mpi4py import MPI

from forming import compat, signals  # noqa: F401
from forming.errors import InputError, KernelFailure
from forming.model import Model
from forming.solver.base import StepResult
from forming.solver.lumped import BodyState, ExternalTerm, assembled
from forming.solver.options import ExplicitOptions
from forming.solver.stepping import StepControl

log = logging.getLogger(__name__)

_CHECK_EVERY = 64  # increments between collective checks for a stop request
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
        self.model = model
        self.options = options or ExplicitOptions()
        comm = model.comm
        self.comm = comm
        bcs = {n: [bc for bc, b in zip(model.dirichlet.bcs, model.dirichlet.bc_bodies,
                                       strict=True) if b == n] for n in model.names}
        self.states = [BodyState(n, model.bodies[n], bcs[n]) for n in model.names]
        by_name = {st.name: st for st in self.states}
        tests = model.test_functions()
        emaps = model.entity_maps or None
        self._internal = [fem.form(b.residual(tests[n]), entity_maps=emaps)
                          for n, b in model.bodies.items()]
        # contact and interface tractions on their own: tool work and friction energy
        self._tools = [ExternalTerm(by_name[name], fem.form(r, entity_maps=emaps), c)
                       for c in model.contacts for name, r in c.residuals(tests).items()]
        self._sides = [ExternalTerm(by_name[name], fem.form(r, entity_maps=emaps))
                       for itf in model.interfaces
                       for name, r in itf.residuals(tests).items()]
        # distributed loads: external forces that are neither contact nor interface
        self._loads = [ExternalTerm(by_name[tr.body], fem.form(
            -ufl.dot(const, tests[tr.body]) * ds, entity_maps=emaps))
            for tr, const, ds in model.tractions]
        # every external term once; the full residual is their sum with the internal forces
        self._terms = [*self._tools, *self._sides, *self._loads]
        # recorded reactions: the residual at a face's prescribed dofs, f_all . w
        self._reactions = [(key, by_name[name], w.x.array[: by_name[name].n_owned])
                           for key, (name, w) in model.dirichlet.reaction_weights.items()]
        self._stiffness = self._stiffness_forms(tests)
        self.mass_added_fraction = self._scale_masses()
        self.tau = 0.0
        self.dt = self._stable_dt()
        self.time_steps = 0
        self.assembly_seconds = 0.0
        self.energy = {"kinetic": 0.0, "internal": 0.0, "friction": 0.0, "damping": 0.0,
                       "external": 0.0}
        self._ke_ie_max = 0.0
        self._balance_max = 0.0
        self._s_end = 0.0
        self._impulse: dict[str, np.ndarray] = {}
        self._reaction_impulse: dict[str, float] = {}
        self._tau_start = 0.0
        self._assemble_forces()  # forces at rest (e.g. a preload) give a_0
        for st in self.states:
            self._accelerate(st)
        log.info("explicit: stable time step %.3g s, about %d increments, mass added %.3g%%",
                 self.dt, int(self.options.loading_time / self.dt) + 1,
                 100 * self.mass_added_fraction)

    # -- time step and mass scaling -------------------------------------------------------
    def _stiffness_forms(self, tests: dict) -> list:
        """Per body: its tangent block and a vector of every penalty its nodes may meet."""
        model = self.model
        jac = model.jacobians()
        estimates = [c.stiffness_estimate(tests) for c in model.constraints]
        out = []
        for i, st in enumerate(self.states):
            # open contacts included; an interface counts twice (the coupling row)
            terms = [e[st.name] for e in estimates if st.name in e]
            pen = sum(terms[1:], terms[0]) if terms else None
            # coupled blocks reach into the other bodies: every body's entity map
            maps = model.entity_maps or None
            out.append((fem.form(jac[i][i], entity_maps=maps),
                        None if pen is None else fem.form(pen, entity_maps=maps)))
        return out

    def _row_sums(self) -> list[np.ndarray]:
        """Per body, the absolute row sums of its tangent plus every contact penalty.

        Gershgorin: the largest eigenvalue of M^-1 K is at most max_i sum_j |K_ij| / m_i,
        so ``2 / sqrt(row_i / m_i)`` bounds the stable time step of node i from below.
        """
        sums = []
        for st, (jac, pen) in zip(self.states, self._stiffness, strict=True):
            st.body.invalidate()
            # elastic unloading is the stiffest response: plastic state frozen
            st.body.update_material(want_tangent=True, frozen=True)
            A = assemble_matrix(jac)
            A.assemble()
            indptr, _cols, data = A.getValuesCSR()
            rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
            local = np.bincount(rows, weights=np.abs(data), minlength=len(indptr) - 1)
            A.destroy()
            f = fem.Function(st.body.V)
            f.x.array[: st.n_owned] = local
            f.x.scatter_forward()
            total = f.x.array.copy()
            if pen is not None:
                total += assembled(pen)
            # one value per node: the stiffest of its three components
            sums.append(np.repeat(total.reshape(-1, 3).max(axis=1), 3))
            st.body.invalidate()
        return sums

    def _scale_masses(self) -> float:
        """Add mass where the stable time step is below the target; the added fraction."""
        target = self.options.target_time_step
        if target is None:
            return 0.0
        added = total = 0.0
        factor = (target / (2.0 * self.options.safety)) ** 2
        for st, k in zip(self.states, self._row_sums(), strict=True):
            st.m = np.maximum(st.m_phys, k * factor)
            added += float(np.sum(st.m[: st.n_owned] - st.m_phys[: st.n_owned]))
            total += float(np.sum(st.m_phys[: st.n_owned]))
        added, total = (self.comm.allreduce(v, op=MPI.SUM) for v in (added, total))
        return added / total

    def _stable_dt(self) -> float:
        """Safety times the Gershgorin bound of the critical time step [s]."""
        omega2 = 0.0
        for st, k in zip(self.states, self._row_sums(), strict=True):
            n = st.n_owned
            free = ~st.fixed[:n]
            if np.any(free):
                omega2 = max(omega2, float(np.max(k[:n][free] / st.m[:n][free])))
        omega2 = self.comm.allreduce(omega2, op=MPI.MAX)
        if omega2 <= 0:
            raise InputError("explicit", "the model has no stiffness: no stable time step")
        return self.options.safety * 2.0 / math.sqrt(omega2)

    # -- one increment ----------------------------------------------------------------------
    def _assemble_forces(self) -> None:
        t0 = time.perf_counter()
        for st in self.states:
            st.body.update_material(want_tangent=False)
        for st, internal in zip(self.states, self._internal, strict=True):
            assembled(internal, st.f_int)
            st.f_all.x.array[:] = st.f_int.x.array
        for term in self._terms:
            term.update()
            term.state.f_all.x.array[:] += term.vec.x.array
        self.assembly_seconds += time.perf_counter() - t0

    def _accelerate(self, st: BodyState) -> None:
        """Acceleration a = -R / m - alpha v, zero where the motion is prescribed."""
        st.a[:] = -st.f_all.x.array / st.m
        if self.options.damping > 0:
            st.a -= self.options.damping * st.v
        st.a[st.fixed] = 0.0

    def _increment(self, dt: float) -> None:
        """Advance by ``dt``: velocity, displacement, load, forces, acceleration, history."""
        model = self.model
        old = []
        for st in self.states:
            n = st.n_owned
            old.append((st.body.u.x.array.copy(), st.f_int.x.array[:n].copy(),
                        st.f_all.x.array[:n].copy(), st.v.copy()))
            # leapfrog: v(n+1/2) = v(n-1/2) + dt a(n); the first half step from rest
            st.v += (dt if self.time_steps else 0.5 * dt) * st.a
            st.body.u.x.array[:] += dt * st.v
        tool_old = [t.contact.tool_offset() for t in self._tools]
        self.tau += dt
        model.set_load(self.options.load(self.tau))
        for st, (u0, *_rest) in zip(self.states, old, strict=True):
            for bc in st.bcs:
                bc.set(st.body.u.x.array)
            st.v[st.fixed] = (st.body.u.x.array[st.fixed] - u0[st.fixed]) / dt
        self._assemble_forces()
        # works over the increment (trapezoidal rule)
        w_int = w_ext = 0.0
        du = {}
        for st, (u0, f0, r0, v0) in zip(self.states, old, strict=True):
            n = st.n_owned
            du[st.name] = st.body.u.x.array[:n] - u0[:n]
            w_int += 0.5 * float((f0 + st.f_int.x.array[:n]) @ du[st.name])
            # all external forces on the free dofs do R = f_int - f_ext; at prescribed
            # dofs the support does the work that changes their kinetic energy
            free = ~st.fixed[:n]
            r = 0.5 * (r0 + st.f_all.x.array[:n])
            w_ext += -float(r[free] @ du[st.name][free])
            fixed = st.fixed[:n]
            w_ext += 0.5 * float(st.m[:n][fixed] @ (st.v[:n][fixed] ** 2 - v0[:n][fixed] ** 2))
        w_ext += w_int
        w_damp = 0.0
        if self.options.damping > 0:  # the damping force alpha m v did work on the nodes
            for st, (_u0, _f0, _r0, v0) in zip(self.states, old, strict=True):
                n = st.n_owned
                free = ~st.fixed[:n]
                w_damp += self.options.damping * float(
                    (st.m[:n] * v0[:n])[free] @ du[st.name][free])
            w_damp = self.comm.allreduce(w_damp, op=MPI.SUM)
        on_bodies = tools = 0.0
        for term in (*self._tools, *self._sides):
            on_bodies += -0.5 * float((term.r_old + term.r_new) @ du[term.state.name])
        for term, off0 in zip(self._tools, tool_old, strict=True):
            # force on the tool, mean of both ends of the increment
            force = 0.5 * self.comm.allreduce(
                (term.r_old + term.r_new).reshape(-1, 3).sum(axis=0), op=MPI.SUM)
            tools += -float(force @ (term.contact.tool_offset() - off0))
            self._impulse[term.contact.name] += force * dt
        for key, st, w in self._reactions:
            self._reaction_impulse[key] += dt * float(st.f_all.x.array[: st.n_owned] @ w)
        w_int, w_ext, on_bodies = (self.comm.allreduce(v, op=MPI.SUM)
                                   for v in (w_int, w_ext, on_bodies))
        # what the tools put in, less what reached the nodes, went into friction (and
        # the penalty springs of contacts and interfaces)
        self.energy["internal"] += w_int
        self.energy["damping"] += w_damp
        self.energy["external"] += w_ext + w_damp - on_bodies + tools
        self.energy["friction"] += tools - on_bodies
        for st in self.states:
            self._accelerate(st)
        model.commit()
        self.time_steps += 1

    def _kinetic(self) -> float:
        """Kinetic energy at the current time: v(n) = v(n-1/2) + dt/2 a(n)."""
        ke = 0.0
        for st in self.states:
            n = st.n_owned
            v = st.v[:n] + 0.5 * self.dt * st.a[:n]
            ke += 0.5 * float(st.m[:n] @ v**2)
        return self.comm.allreduce(ke, op=MPI.SUM)

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

    def solve(self) -> StepResult:
        """Integrate in time until the load parameter reaches the interval's end."""
        t0 = time.perf_counter()
        tau_end = self.options.time_of(self._s_end)
        n0 = self.time_steps
        reason = ""
        ok = True
        try:
            if self.time_steps:  # the constructor evaluated the bound at the start
                self.dt = self._stable_dt()
            while self.tau < tau_end * (1 - 1e-12):
                n_left = math.ceil((tau_end - self.tau) / self.dt - 1e-9)
                dt = (tau_end - self.tau) / max(n_left, 1)
                self._increment(dt)
                if self.time_steps % _CHECK_EVERY:
                    continue
                # collective, so that every rank stops at the same increment
                finite = all(np.all(np.isfinite(st.v)) for st in self.states)
                code = self.comm.allreduce(2 * int(not finite)
                                           + int(signals.requested() is not None), op=MPI.MAX)
                if code:
                    ok = False
                    reason = ("velocities not finite (unstable time step)" if code >= 2
                              else "interrupted")
                    break
            if ok and not all(np.all(np.isfinite(st.v)) for st in self.states):
                ok, reason = False, "velocities not finite (unstable time step)"
        except KernelFailure as exc:
            ok, reason = False, f"point kernel failed: {exc}"
        ok = self.comm.allreduce(ok, op=MPI.LAND)
        if ok:
            ke = self._kinetic()
            self.energy["kinetic"] = ke
            ie = self.energy["internal"]
            if self._s_end >= 0.05 and ie > 0:
                self._ke_ie_max = max(self._ke_ie_max, ke / ie)
            self._balance_max = max(self._balance_max, abs(self.balance()))
        elif not reason:
            reason = "failed on another rank"
        return StepResult(ok, self.time_steps - n0, [], reason, time.perf_counter() - t0)

    def accept(self, force_scale: float) -> None:
        """Nothing to carry over: the state lives in the solver's vectors."""
        del force_scale

    def snapshot(self) -> tuple:
        """Velocities, accelerations, force vectors, time, energies and counters."""
        return ([(st.v.copy(), st.a.copy(), st.f_int.x.array.copy(),
                  st.f_all.x.array.copy()) for st in self.states],
                [t.vec.x.array.copy() for t in self._terms],
                self.tau, dict(self.energy), self.time_steps, self.dt,
                self._ke_ie_max, self._balance_max)

    def restore(self, snap: tuple) -> None:
        """Return velocities, energies and time to a snapshot."""
        (states, terms, self.tau, energy, self.time_steps, self.dt, self._ke_ie_max,
         self._balance_max) = snap
        self.energy = dict(energy)
        for st, (v, a, fi, fa) in zip(self.states, states, strict=True):
            st.v[:], st.a[:] = v, a
            st.f_int.x.array[:], st.f_all.x.array[:] = fi, fa
        for t, vec in zip(self._terms, terms, strict=True):
            t.vec.x.array[:] = vec

    def snapshot_layout(self) -> tuple:
        """Velocities, accelerations and force vectors are per body; the rest is global."""
        def on(st: BodyState):
            return st.body.domain.layout(st.body.V)

        return ([(on(st),) * 4 for st in self.states], [on(t.state) for t in self._terms],
                None, None, None, None, None, None)

    # -- reporting --------------------------------------------------------------------------
    def balance(self) -> float:
        """Energy balance: kinetic + internal + friction + damping - external work [N mm]."""
        e = self.energy
        return e["kinetic"] + e["internal"] + e["friction"] + e["damping"] - e["external"]

    def tool_force(self, contact) -> np.ndarray:
        """Mean force on the tool over the output interval (impulse over time).

        A penalty contact in explicit dynamics rings at the contact frequency, so the
        force at an instant scatters; like the anti-aliasing filter of Abaqus/Explicit's
        history output, the force reported is the mean over the interval. At the start
        (no interval yet) it is the force of the current state.
        """
        span = self.tau - self._tau_start
        if span > 0 and contact.name in self._impulse:
            return self._impulse[contact.name] / span
        return contact.force()

    def reaction(self, key: str) -> float:
        """Mean static reaction over the output interval.

        The static reaction is the residual at the face's prescribed dofs, without the
        inertia of the moving nodes.
        """
        span = self.tau - self._tau_start
        if span > 0 and key in self._reaction_impulse:
            return self.comm.allreduce(self._reaction_impulse[key], op=MPI.SUM) / span
        return self.model.dirichlet.reaction(key)

    def history_columns(self, result: StepResult) -> dict[str, float]:
        """Time increments of the interval, time, time step and the energy ledger [N mm]."""
        e = self.energy
        return {"time_increments": result.work, "time_s": self.tau, "time_step_s": self.dt,
                "energy_kinetic_Nmm": e["kinetic"], "energy_internal_Nmm": e["internal"],
                "energy_friction_Nmm": e["friction"], "energy_damping_Nmm": e["damping"],
                "work_external_Nmm": e["external"], "energy_balance_Nmm": self.balance()}

    def metrics(self) -> dict[str, float | bool]:
        """Figures every explicit run reports (``summary.json`` metrics)."""
        ext = abs(self.energy["external"])
        return {
            "kinetic_to_internal_max": self._ke_ie_max,
            "quasi_static": self._ke_ie_max <= self.options.quasi_static_limit,
            "mass_added_fraction": self.mass_added_fraction,
            "energy_balance_error_rel": self._balance_max / ext if ext > 0 else 0.0,
        }

    def timing(self) -> dict[str, float]:
        """Figures for ``summary.json`` timing."""
        return {"time_steps": self.time_steps, "stable_time_step_s": self.dt,
                "loading_time_s": self.options.loading_time,
                "assembly_s": self.comm.allreduce(self.assembly_seconds) / self.comm.size}

    def parameters(self) -> dict:
        """The explicit settings the run used."""
        return {"explicit": asdict(self.options)}

    def validity(self) -> dict[str, bool]:
        """Quasi-static (kinetic below the limit of internal energy), little added mass."""
        return {"quasi_static": self._ke_ie_max <= self.options.quasi_static_limit,
                "mass_added_below_limit": self.mass_added_fraction <= MASS_ADDED_LIMIT}

    def warnings(self) -> list[str]:
        """A run that is not quasi-static, or that added much mass."""
        out = []
        if self._ke_ie_max > self.options.quasi_static_limit:
            out.append(f"explicit: kinetic energy reached {self._ke_ie_max:.1%} of the internal"
                       f" energy (quasi-static limit {self.options.quasi_static_limit:.0%}): "
                       "inertia distorts the answer; lengthen explicit.loading_time")
        if self.mass_added_fraction > MASS_ADDED_LIMIT:
            out.append(f"explicit: mass scaling added {self.mass_added_fraction:.1%} of the "
                       f"mass (above {MASS_ADDED_LIMIT:.0%}); raise explicit.loading_time or "
                       "lower explicit.target_time_step")
        return out
