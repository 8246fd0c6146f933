"""Implicit solver: Newton (PETSc SNES) on the quasi-static equilibrium of a model."""

from __future__ import annotations

import itertools
import logging
import time

import numpy as np
from dolfinx import fem  # noqa: I001
from dolfinx.fem.petsc import NonlinearProblem, assemble_jacobian, assemble_residual, assign
from mpi4py import MPI
from petsc4py import PETSc

from forming import compat, signals  # noqa: F401
from forming.errors import InputError, KernelFailure
from forming.model import Model
from forming.solver.base import StepResult
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

log = logging.getLogger(__name__)
_ids = itertools.count()

_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


def _rigid_body_modes(V: fem.FunctionSpace) -> PETSc.NullSpace:
    """Near-null space of 3D elasticity (translations and rotations) for GAMG."""
    x = V.tabulate_dof_coordinates()
    bs = V.dofmap.index_map_bs
    n = V.dofmap.index_map.size_local
    vecs = [fem.Function(V) for _ in range(6)]
    for i in range(3):
        vecs[i].x.array.reshape(-1, bs)[:n, i] = 1.0
    xs = x[:n]
    vecs[3].x.array.reshape(-1, bs)[:n, 0] = -xs[:, 1]
    vecs[3].x.array.reshape(-1, bs)[:n, 1] = xs[:, 0]
    vecs[4].x.array.reshape(-1, bs)[:n, 1] = -xs[:, 2]
    vecs[4].x.array.reshape(-1, bs)[:n, 2] = xs[:, 1]
    vecs[5].x.array.reshape(-1, bs)[:n, 0] = xs[:, 2]
    vecs[5].x.array.reshape(-1, bs)[:n, 2] = -xs[:, 0]
    from dolfinx import la

    la.orthonormalize([v.x for v in vecs])
    return PETSc.NullSpace().create(vectors=[v.x.petsc_vec for v in vecs], comm=V.mesh.comm)


class ImplicitSolver:
    """Newton solve of one load step of a :class:`~forming.model.Model`.

    Args:
        model: The model.
        options: Newton and linear-solver settings.
    """

    kind = "implicit"
    work_name = "Newton iterations"
    work_column = "newton_iterations"
    retries_on_failure = True  # a step that fails is cut back and retried

    def __init__(self, model: Model, options: NewtonOptions | None = None):
        self.model = model
        self.options = options or NewtonOptions()
        self.prefix = f"forming{next(_ids) or ''}_"
        opts = self.options.petsc_options()
        cmdline = PETSc.Options()
        opts = {k: v for k, v in opts.items() if not cmdline.hasName(f"{self.prefix}{k}")}
        bodies = list(model.bodies.values())
        self._bodies = bodies
        bcs = model.dirichlet.bcs
        if len(bodies) == 1:
            body = bodies[0]
            self._u = body.u
            self.problem = NonlinearProblem(
                model.residuals()[0], body.u, bcs=bcs, J=model.jacobians()[0][0],
                petsc_options_prefix=self.prefix, petsc_options=opts,
                entity_maps=model.entity_maps or None,
            )
        else:
            # one monolithic matrix over all bodies' unknowns (MUMPS cannot factor MATNEST)
            self._u = [b.u for b in bodies]
            self.problem = NonlinearProblem(
                model.residuals(), self._u, bcs=bcs, J=model.jacobians(), kind="mpi",
                petsc_options_prefix=self.prefix, petsc_options=opts,
                entity_maps=model.entity_maps or None,
            )
        snes = self.problem.solver
        self._fctx = {"u": self._u, "residual": self.problem.F, "jacobian": self.problem.J,
                      "bcs": bcs}
        if (blocks := self.problem.b.getAttr("_blocks")) is not None:
            self._fctx["_blocks"] = blocks
        self._jctx = {"u": self._u, "jacobian": self.problem.J, "preconditioner": None,
                      "bcs": bcs}
        snes.setFunction(self._residual, self.problem.b)
        snes.setJacobian(self._jacobian, self.problem.A, None)
        snes.setMonitor(self._monitor)
        if self.options.linear_solver == "gamg":
            if len(bodies) > 1:
                raise InputError("solver.linear_solver",
                                 "'gamg' supports one body; use 'mumps' for several bodies")
            self.problem.A.setNearNullSpace(_rigid_body_modes(bodies[0].V))
        self._residuals: list[float] = []
        self._failure: str | None = None
        self._u_prev: list[np.ndarray] | None = None
        self.assembly_seconds = 0.0
        self._force_scale = 0.0
        self._u_before: list[np.ndarray] | None = None
        self._work_total = 0
        self._work_accepted = 0
        self._steps = 0
        self._last_work = 0
        self._user_atol = "snes_atol" not in opts  # set on the command line: keep it

    # -- SNES callbacks --------------------------------------------------------------
    def _update_materials(self, x) -> str | None:
        """Copy ``x`` into the displacements and evaluate every body's material."""
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        assign(x, self._u)
        for b in self._bodies:
            b.u.x.scatter_forward()
        try:
            # the tangent too: the Dirichlet lifting inside the residual uses the Jacobian
            for b in self._bodies:
                b.update_material(want_tangent=True)
        except KernelFailure as exc:
            return str(exc)
        return None

    def _residual(self, snes, x, b) -> None:
        t0 = time.perf_counter()
        failure = self._update_materials(x)
        if failure is None and signals.requested() is not None:
            failure = "interrupted"  # abandon the step: the lifecycle rolls it back
        # collective decision: a rank that skipped assembly would leave the others waiting
        # in the ghost exchange
        if self.model.comm.allreduce(failure is not None, op=MPI.LOR):
            self._failure = failure or "a point kernel failed on another rank"
            b.set(np.nan)
            return
        assemble_residual(snes, x, b, **self._fctx)
        self.assembly_seconds += time.perf_counter() - t0

    def _jacobian(self, snes, x, A, P) -> None:
        t0 = time.perf_counter()
        failure = self._update_materials(x)  # never raise here: SNES would be unusable
        if failure:
            self._failure = failure
        assemble_jacobian(snes, x, A, P, **self._jctx)
        self.assembly_seconds += time.perf_counter() - t0

    def _monitor(self, snes, its, norm) -> None:
        self._residuals.append(float(norm))

    # -- evaluation at a given iterate (verification) ------------------------------------
    def residual_at(self, x: PETSc.Vec, b: PETSc.Vec) -> None:
        """The residual at ``x`` into ``b``, exactly as Newton evaluates it."""
        self._residual(self.problem.solver, x, b)

    def jacobian_at(self, x: PETSc.Vec) -> PETSc.Mat:
        """The Jacobian at ``x``, exactly as Newton assembles it (the solver's matrix)."""
        self._jacobian(self.problem.solver, x, self.problem.A, None)
        return self.problem.A

    def unknowns(self) -> PETSc.Vec:
        """A vector shaped like the unknowns of all bodies (block order)."""
        return self.problem.x.duplicate()

    # -- step lifecycle ----------------------------------------------------------------
    def step_control(self, requested: StepControl) -> StepControl:
        """The job's load steps, adaptive."""
        return requested

    def advance(self, t_old: float, t_new: float, dt_old: float) -> None:
        """Apply the load at ``t_new`` and predict the displacement."""
        self._u_before = self.model.displacements()
        self.model.set_load(t_new)
        self.predict(t_new, t_old, dt_old)

    def predict(self, t_new: float, t_old: float, dt_old: float) -> None:
        """Initial guess for the step to ``t_new`` (the load is already set)."""
        if self.options.predictor == "extrapolate" and self._u_prev is not None and dt_old > 0:
            ratio = (t_new - t_old) / dt_old
            for b, prev in zip(self._bodies, self._u_prev, strict=True):
                b.u.x.array[:] += ratio * (b.u.x.array - prev)
        for b in self._bodies:
            b.invalidate()

    def _newton(self) -> tuple[bool, str]:
        snes = self.problem.solver
        self._failure = None
        try:
            self.problem.solve()
            code = snes.getConvergedReason()
            reason = _REASONS.get(code, str(code))
            ok = code > 0 and all(np.isfinite(self._residuals))
        except (KernelFailure, PETSc.Error) as exc:
            ok, reason = False, f"error: {exc}"
        if self._failure and not ok:
            reason = f"{reason} ({self._failure})"
        return ok, reason

    def solve(self) -> StepResult:
        """Run Newton from the current iterate.

        With contact, repeat with updated multipliers (Uzawa) until every pair's
        constraint violation is within its tolerance.
        """
        self._residuals = []
        t0 = time.perf_counter()
        snes = self.problem.solver
        if not self._user_atol:
            snes.setTolerances(atol=max(self.options.atol,
                                        self.options.force_rtol * self._force_scale))
        iterations = 0
        contacts = self.model.constraints
        ok, reason, aug = False, "", 0
        for aug in range(self.options.max_augmentations + 1):
            ok, reason = self._newton()
            iterations += snes.getIterationNumber()
            if not ok or not contacts:
                break
            worst = max(c.violation() / c.tolerance for c in contacts)
            if worst <= 1.0:
                break  # keep the multipliers the solution was computed with
            if aug == self.options.max_augmentations:
                continue  # no further solve: leave the loop through its else branch
            for c in contacts:
                c.augment()
        else:
            ok, reason = False, (f"contact constraints not met after "
                                 f"{self.options.max_augmentations} augmentations")
        for b in self._bodies:
            b.invalidate()
        self._work_total += iterations
        self._last_work = iterations
        return StepResult(ok, iterations, list(self._residuals), reason,
                          time.perf_counter() - t0, aug)

    def accept(self, force_scale: float) -> None:
        """Keep what the next step needs.

        The displacement before the step (the extrapolating predictor) and the step's
        force scale (``force_rtol``).
        """
        self._u_prev = self._u_before
        self._force_scale = force_scale
        self._steps += 1
        self._work_accepted += self._last_work

    def snapshot(self) -> tuple:
        """The predictor's state and the force scale."""
        return (self._u_prev, self._force_scale, self._steps, self._work_accepted)

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""
        self._u_prev, self._force_scale, self._steps, self._work_accepted = snap

    def snapshot_layout(self) -> tuple:
        """The predictor's displacements are per body; the rest is global."""
        return ([b.domain.layout(b.V) for b in self._bodies], None, None, None)

    # -- reporting ---------------------------------------------------------------------
    def tool_force(self, contact) -> np.ndarray:
        """The static force of the converged state."""
        return contact.force()

    def reaction(self, key: str) -> float:
        """The static reaction of the converged state."""
        return self.model.dirichlet.reaction(key)

    def history_columns(self, result: StepResult) -> dict[str, float]:
        """Newton iterations and last residual of the step; the Uzawa passes with contact."""
        row = {"newton_iterations": result.work, "residual": result.residual}
        if self.model.constraints:
            row["augmentations"] = result.augmentations
        return row

    def metrics(self) -> dict:
        """No solver metrics."""
        return {}

    def timing(self) -> dict:
        """Newton iterations in total (rejected steps included) and per accepted step."""
        return {"newton_iterations": self._work_total,
                "newton_per_step": self._work_accepted / max(self._steps, 1),
                "assembly_s": self.model.comm.allreduce(self.assembly_seconds)
                / self.model.comm.size}

    def parameters(self) -> dict:
        """Nothing beyond the case's parameters."""
        return {}

    def validity(self) -> dict[str, bool]:
        """Every accepted step is an equilibrium: nothing more to check."""
        return {}

    def warnings(self) -> list[str]:
        """None."""
        return []
