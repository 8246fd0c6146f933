"""Implicit solver: Newton (PETSc SNES) on the quasi-static equilibrium of a model."""

from __future__ import annotations

import itertools
import logging
import time

import numpy as np
from dolfinx.fem.petsc import NonlinearProblem, assemble_jacobian, assemble_residual, assign
from mpi4py import MPI
from petsc4py import PETSc

from forming import compat, signals  # noqa: F401
from forming.errors import KernelFailure
from forming.model import Model
from forming.solver import linear
from forming.solver.base import StepResult
from forming.solver.callbacks import assemble_held_residual, weak
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl
from forming.solver.tangents import compiled_jacobian
from forming.springs import SpringRelease

log = logging.getLogger(__name__)
_ids = itertools.count()

_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


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
        bodies = list(model.bodies.values())
        unknowns = sum(b.V.dofmap.index_map.size_global * b.V.dofmap.index_map_bs
                       for b in bodies)
        self.options = (options or NewtonOptions()).for_size(unknowns)
        self.prefix = f"forming{next(_ids) or ''}_"
        opts = self.options.petsc_options()
        cmdline = PETSc.Options()
        opts = {k: v for k, v in opts.items() if not cmdline.hasName(f"{self.prefix}{k}")}
        self._bodies = bodies
        self._dirichlet = model.dirichlet
        bcs = model.dirichlet.bcs
        if len(bodies) == 1:
            body = bodies[0]
            self._u = body.u
            self.problem = NonlinearProblem(
                model.residuals()[0], body.u, bcs=bcs, J=model.jacobians()[0][0],
                petsc_options_prefix=self.prefix, petsc_options=opts,
                entity_maps=model.entity_maps or None, jit_options=compat.SOLVE_JIT_OPTIONS,
            )
        else:
            # one monolithic matrix over all bodies' unknowns (MUMPS cannot factor MATNEST)
            self._u = [b.u for b in bodies]
            self.problem = NonlinearProblem(
                model.residuals(), self._u, bcs=bcs, J=model.jacobians(), kind="mpi",
                petsc_options_prefix=self.prefix, petsc_options=opts,
                entity_maps=model.entity_maps or None, jit_options=compat.SOLVE_JIT_OPTIONS,
            )
        # MUMPS reads its options at its first factorisation: a solver that never gets
        # there (a Taylor test, a run stopped before its first solve) would leave them
        # "unused" in PETSc's report at exit
        for key in opts:
            if "mat_mumps_" in key:  # (also those of a refined LU's inner solvers)
                cmdline.getString(f"{self.prefix}{key}", None)
        snes = self.problem.solver
        if model.sliding:  # entries between bodies that the forms' sparsity does not have
            self.problem.A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        if len(bodies) > 1 and self.options.zeros == "drop":
            # An interface's facet forms fill an element matrix over both cells of the
            # facet, of which the vertex rule makes most entries exactly zero (59% of
            # the stored entries of the 8,8,2 sandwich hemisphere's Jacobian). Zeros are
            # not inserted, the pattern keeps only what was ever non-zero, and an entry
            # that becomes non-zero later is added (PETSc then redoes the symbolic LU).
            self.problem.A.setOption(PETSc.Mat.Option.IGNORE_ZERO_ENTRIES, True)
            self.problem.A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        self._fctx = {"u": self._u, "residual": self.problem.F, "jacobian": self.problem.J,
                      "bcs": bcs}
        if (blocks := self.problem.b.getAttr("_blocks")) is not None:
            self._fctx["_blocks"] = blocks
        self._jctx = {"u": self._u, "jacobian": self.problem.J, "preconditioner": None,
                      "bcs": bcs}
        # SNES keeps its callbacks where Python's garbage collector does not look: bound
        # methods would tie the solver (and its model, forms, functions and their MPI
        # communicators) into a cycle that is never freed
        snes.setFunction(weak(self._residual), self.problem.b)
        snes.setJacobian(weak(self._jacobian), self.problem.A, None)
        snes.setMonitor(weak(self._monitor))
        self._one_loop = self.options.multipliers == "newton" and bool(model.constraints)
        if self._one_loop or self.options.stall:
            snes.setConvergenceTest(weak(self._converged))
        self._fnorm0, self._recent = 0.0, []  # a solve's first norm; those since an update
        self._updates = 0
        self._compiled = compiled_jacobian(model, self.problem.A, self.options.jacobian)
        linear.configure(self.problem.A, [b.V for b in bodies], self.options)
        self._residuals: list[float] = []
        self._failure: str | None = None
        self._u_prev: list[np.ndarray] | None = None
        # cost split: material kernels, assembly (callbacks less kernels), SNES (all of
        # Newton; the linear solves are what remains), contact checks and updates
        self.assembly_seconds = 0.0
        self._kernel_s = 0.0
        self._newton_s = 0.0
        self._contact_s = 0.0
        self._force_scale = 0.0
        self._u_before: list[np.ndarray] | None = None
        self._extrapolated = False  # the step's guess came from the extrapolating predictor
        self._work_total = 0
        self._work_accepted = 0
        self._steps = 0
        self._last_work = 0
        self._user_atol = "snes_atol" not in opts  # set on the command line: keep it
        self._release = SpringRelease([*model.interfaces, *model.sliding],
                                      self.options.spring_release)

    @property
    def jacobian_kind(self) -> str:
        """``compiled`` (element matrices without forms) or ``forms``."""
        return "forms" if self._compiled is None else "compiled"

    # -- SNES callbacks --------------------------------------------------------------
    def _update_materials(self, x) -> str | None:
        """Copy ``x`` into the displacements and evaluate every body's material."""
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        assign(x, self._u)
        for b in self._bodies:
            b.u.x.scatter_forward()
        t0 = time.perf_counter()
        try:
            # the tangent too: the Dirichlet lifting inside the residual uses the Jacobian
            for b in self._bodies:
                b.update_material(want_tangent=True)
        except KernelFailure as exc:
            return str(exc)
        finally:
            self._kernel_s += time.perf_counter() - t0
        self.model.track()
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
        if self._dirichlet.held():
            assemble_held_residual(x, b, **self._fctx)
        else:
            assemble_residual(snes, x, b, **self._fctx)
        self.model.add_residual(b)
        if self._failure is None and not np.isfinite(b.norm()):
            self._failure = self._why_not_finite()
        self.assembly_seconds += time.perf_counter() - t0

    def _why_not_finite(self) -> str:
        """Why an assembled residual is not finite (collective).

        A body whose stress is a UFL form (a fabric's ``ln det F``) has no kernel to
        report an inverted point: its smallest ``det F`` names it.
        """
        bad = [f"{b.name!r} (det F down to {d:.3g})" for b in self._bodies
               if (d := b.min_det_F()) <= 0.0]
        if bad:
            return "inverted elements (det F <= 0) in body " + ", ".join(bad)
        return "a non-finite residual with no inverted element"

    def _jacobian(self, snes, x, A, P) -> None:
        t0 = time.perf_counter()
        failure = self._update_materials(x)  # never raise here: SNES would be unusable
        if failure:
            self._failure = failure
        if self._compiled is not None:
            self._compiled.assemble(A)
        else:
            assemble_jacobian(snes, x, A, P, **self._jctx)
        self.model.add_jacobian(A)
        self.assembly_seconds += time.perf_counter() - t0

    def _monitor(self, snes, its, norm) -> None:
        self._residuals.append(float(norm))

    # -- contact multipliers inside Newton (multipliers="newton") -------------------------
    def _violation(self) -> float:
        """Largest constraint violation at the current iterate, in tolerance units."""
        t0 = time.perf_counter()
        worst = max((c.violation() / c.tolerance for c in self.model.constraints),
                    default=0.0)
        self._contact_s += time.perf_counter() - t0
        return worst

    def _update_multipliers(self) -> None:
        """Every constraint's multipliers take the tractions of the current iterate."""
        t0 = time.perf_counter()
        for c in self.model.constraints:
            c.augment()
        self._contact_s += time.perf_counter() - t0
        self._updates += 1

    def _augment(self, snes) -> None:
        """Multipliers updated inside the Newton solve, and the residual recomputed.

        The residual vector SNES solves with next is overwritten, so the following
        Newton step is for the new multipliers. (SNES's own copy of the residual norm
        stays the old one; only the backtracking line search reads it.)
        """
        self._update_multipliers()
        self._residual(snes, snes.getSolution(), snes.getFunction()[0])

    def _converged(self, snes, its: int, norms) -> int:
        """SNES's residual test, then the constraints: one Newton loop per step.

        The residual test is PETSc's default (``atol``, or ``rtol`` times the step's first
        residual). A residual within it whose multipliers would still change by more
        than the contact tolerance does not end the solve: the multipliers take the
        tractions (:meth:`_augment`) and Newton goes on from the same iterate with the
        new residual. Below the tolerance the multipliers stay, so the converged
        traction is the one the solution was computed with. With ``stall``, a residual
        that fell by less than a tenth over that many iterations (since the solve began
        or the multipliers last changed it) ends the solve.
        """
        _xnorm, _ynorm, fnorm = norms
        rtol, atol, _stol, max_it = snes.getTolerances()
        if its == 0:
            self._fnorm0, self._recent = fnorm, []
        self._recent.append(fnorm)
        if not np.isfinite(fnorm):  # (a failed line-search trial is not the iterate)
            return PETSc.SNES.ConvergedReason.DIVERGED_FUNCTION_NANORINF
        absolute = fnorm < atol
        if absolute or (its > 0 and fnorm <= rtol * self._fnorm0):
            if self._violation() <= 1.0:
                return (PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS if absolute
                        else PETSc.SNES.ConvergedReason.CONVERGED_FNORM_RELATIVE)
            if its < max_it and self._updates < self.options.max_augmentations:
                self._augment(snes)
                self._recent = []  # a new residual: the stall window starts again
        if its >= max_it:
            return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
        n = self.options.stall
        if n and len(self._recent) > n and fnorm > 0.9 * self._recent[-1 - n]:
            self._failure = f"stalled: the residual fell by less than 10% in {n} iterations"
            return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
        return PETSc.SNES.ConvergedReason.ITERATING

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
        self._extrapolated = (self.options.predictor == "extrapolate"
                              and self._u_prev is not None and dt_old > 0)
        if self._extrapolated:
            ratio = (t_new - t_old) / dt_old
            for b, prev in zip(self._bodies, self._u_prev, strict=True):
                b.u.x.array[:] += ratio * (b.u.x.array - prev)
        for b in self._bodies:
            b.invalidate()

    def _newton(self) -> tuple[bool, str]:
        snes = self.problem.solver
        self._failure = None
        t0 = time.perf_counter()
        try:
            self.problem.solve()
            code = snes.getConvergedReason()
            reason = _REASONS.get(code, str(code))
            ok = code > 0 and all(np.isfinite(self._residuals))
        except (KernelFailure, PETSc.Error) as exc:
            ok, reason = False, f"error: {exc}"
        self._newton_s += time.perf_counter() - t0
        if self._failure and not ok:  # (a stall is no PETSc reason: its own words)
            reason = (self._failure if self._failure.startswith("stalled")
                      else f"{reason} ({self._failure})")
        return ok, reason

    def solve(self) -> StepResult:
        """Run Newton from the current iterate.

        With contact, the multipliers converge inside the one Newton solve
        (``multipliers="newton"``), or Newton is repeated with updated multipliers
        (``"uzawa"``) until every pair's constraint violation is within its tolerance;
        :attr:`StepResult.augmentations` counts the multiplier updates either way.
        """
        self._residuals = []
        t0 = time.perf_counter()
        snes = self.problem.solver
        if not self._user_atol:
            snes.setTolerances(atol=max(self.options.atol,
                                        self.options.force_rtol * self._force_scale))
        iterations = 0
        uzawa = bool(self.model.constraints) and not self._one_loop
        ok, reason = False, ""
        self._updates = 0
        for aug in range(self.options.max_augmentations + 1):
            ok, reason = self._newton()
            if not ok and aug == 0 and snes.getIterationNumber() == 0 and self._extrapolated:
                # the extrapolated guess itself failed (an element it inverts, where the
                # last step moved fast): start again from the last converged state
                log.info("step: the extrapolated guess failed (%s); Newton restarts from "
                         "the last converged state", reason)
                for b, u in zip(self._bodies, self._u_before, strict=True):
                    b.u.x.array[:] = u
                    b.invalidate()
                self._extrapolated = False
                ok, reason = self._newton()
            iterations += snes.getIterationNumber()
            if not ok or not uzawa:
                break
            if self._violation() <= 1.0:
                break  # keep the multipliers the solution was computed with
            if aug < self.options.max_augmentations:
                self._update_multipliers()
        else:
            ok, reason = False, (f"contact constraints not met after "
                                 f"{self.options.max_augmentations} augmentations")
        first = iterations
        if ok and self._release.active:
            its, failure = self._release_step(uzawa)
            iterations += its
            ok, reason = failure is None, failure or reason
        for b in self._bodies:
            b.invalidate()
        final = False
        if ok and (met := self.model.surfaces_meet()) is not None:
            ok, reason, final = False, met, True
        self._work_total += iterations
        self._last_work = iterations
        return StepResult(ok, iterations, list(self._residuals), reason,
                          time.perf_counter() - t0, self._updates, final, first)

    def _release_step(self, uzawa: bool) -> tuple[int, str | None]:
        """Solve the converged step again with the springs relaxed (forming.springs).

        Keeps that answer if it converges (and, with Uzawa, meets the constraints);
        otherwise returns to the first, re-evaluated. Returns the Newton iterations and
        why the step fails after all (an interrupt during the re-evaluation), or None.
        """
        # the displacements and the multipliers (which Newton updates with contact)
        keep = self.model.snapshot(), list(self._residuals)
        with self._release.relaxed():
            ok, reason = self._newton()
            ok = ok and not (uzawa and self._violation() > 1.0)
        if not self._release.record(ok, reason):
            self.model.restore(keep[0])
            self._residuals, self._failure = keep[1], None
            its = self.problem.solver.getIterationNumber()
            assign(self._u, self.problem.x)  # the trial state of the answer kept
            self._residual(self.problem.solver, self.problem.x, self.problem.b)
            return its, self._failure
        return self.problem.solver.getIterationNumber(), None

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
        """Newton iterations and the cost split, rank means [s].

        ``newton_iterations`` counts rejected steps too; ``newton_per_step`` is over
        accepted steps. ``kernel_s`` is the material kernels inside Newton, ``assembly_s``
        the residual and Jacobian callbacks less the kernels, ``linear_solve_s`` the rest
        of Newton (factorisation and solves, less the multiplier updates made inside it),
        ``contact_s`` the constraint checks and multiplier updates; ``per_iteration_ms``
        divides each by the Newton iterations; ``linear_solver`` names the solver used
        (``auto`` chosen for the model's size), ``lu_precision`` the precision of its
        factorisation (the same); ``jacobian_nonzeros`` is the entries the Jacobian stores
        at the end, over ranks, ``jacobian_zeros`` whether its exact zeros were dropped or
        kept, ``jacobian`` whether the body's tangent was ``compiled`` or from its
        ``forms``, ``jacobian_mallocs`` PETSc's count of allocations while entries were
        inserted into the Jacobian over the run (MatGetInfo's ``mallocs``: entries outside
        its pattern); with an approximate LU (single precision or compressed),
        ``linear_solves``, ``refinement_iterations``, ``exact_fallbacks`` and
        ``exact_only`` (:class:`~forming.solver.linear.RefinedLU`).
        """
        comm = self.model.comm

        def mean(x: float) -> float:
            return comm.allreduce(x) / comm.size

        kernel = mean(self._kernel_s)
        callbacks = mean(self.assembly_seconds)
        contact = mean(self._contact_s)
        inside = contact if self._one_loop else 0.0  # (Uzawa checks between the solves)
        split = {"kernel_s": kernel, "assembly_s": callbacks - kernel,
                 "linear_solve_s": mean(self._newton_s) - callbacks - inside,
                 "contact_s": contact}
        its = max(self._work_total, 1)
        info = self.problem.A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)
        return {"linear_solver": self.options.linear_solver,
                "lu_precision": self.options.lu_precision,
                "jacobian_zeros": self.options.zeros,
                "jacobian": self.jacobian_kind,
                "jacobian_nonzeros": int(info["nz_used"]),
                "jacobian_mallocs": int(info["mallocs"]),
                "newton_iterations": self._work_total,
                "newton_per_step": self._work_accepted / max(self._steps, 1),
                "assembly_s": split["assembly_s"],
                "newton_split_s": split,
                "per_iteration_ms": {k.removesuffix("_s"): 1e3 * v / its
                                     for k, v in split.items()},
                **self.model.search_timing(), **self._release.summary(),
                **(refined.counts() if (refined := linear.refined_lu(
                    self.problem.solver.getKSP())) is not None else {})}

    def parameters(self) -> dict:
        """Nothing beyond the case's parameters."""
        return {}

    def validity(self) -> dict[str, bool]:
        """Every accepted step is an equilibrium: nothing more to check."""
        return {}

    def warnings(self) -> list[str]:
        """None."""
        return []

    def close(self) -> None:
        """Destroy the Newton solver, its matrix and vectors (collective; see Solver)."""
        problem = self.problem
        for obj in (problem.solver, problem.A, problem.P_mat, problem.b, problem.x):
            if obj is not None:
                obj.destroy()
