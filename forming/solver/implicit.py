"""Implicit solver: Newton (PETSc SNES) on the quasi-static equilibrium of a model."""

from __future__ import annotations

import itertools
import logging
import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from dolfinx import fem  # noqa: I001
from dolfinx.fem.petsc import NonlinearProblem, assemble_jacobian, assemble_residual, assign
from mpi4py import MPI
from petsc4py import PETSc

from forming import compat  # noqa: F401
from forming.errors import InputError
from forming.model import KernelFailure, Model

log = logging.getLogger(__name__)
_ids = itertools.count()

_REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


@dataclass(frozen=True)
class NewtonOptions:
    """Newton and linear-solver settings.

    Attributes:
        linear_solver: ``"mumps"`` (direct LU, default) or ``"gamg"`` (GMRES + smoothed
            aggregation AMG with rigid-body near-null space, for large models).
        rtol: Residual reduction relative to the first residual of a step.
        atol: Absolute residual norm [N].
        force_rtol: Newton also stops when the residual norm is below this fraction of
            the force scale of the last converged step (largest reaction or tool force).
            1e-4 accepts a force imbalance 50 times smaller than Abaqus/Standard's default
            (5e-3 of the average force); it ends the slow tail that stick-slip switching
            of unloaded contact nodes causes. 0 switches it off.
        max_it: Newton iterations before a step counts as failed.
        line_search: ``"basic"`` (full Newton step) or ``"bt"`` (backtracking).
        predictor: ``"extrapolate"`` (linear in the load parameter) or ``"previous"``.
        max_augmentations: Uzawa updates of the contact multipliers per step before the
            step counts as failed.
        petsc: Extra PETSc options for the SNES prefix, overriding the defaults; the
            command line (``-forming_<key> value``) overrides both.
    """

    linear_solver: Literal["mumps", "gamg"] = "mumps"
    rtol: float = 1e-9
    atol: float = 1e-8
    force_rtol: float = 1e-4
    max_it: int = 25
    line_search: Literal["basic", "bt"] = "basic"
    predictor: Literal["extrapolate", "previous"] = "extrapolate"
    max_augmentations: int = 25
    petsc: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.linear_solver not in ("mumps", "gamg"):
            raise InputError("solver.linear_solver", f"must be 'mumps' or 'gamg', got "
                             f"{self.linear_solver!r}")
        if self.line_search not in ("basic", "bt"):
            raise InputError("solver.line_search", f"must be 'basic' or 'bt', got "
                             f"{self.line_search!r}")
        if self.predictor not in ("extrapolate", "previous"):
            raise InputError("solver.predictor", f"must be 'extrapolate' or 'previous', got "
                             f"{self.predictor!r}")
        if not self.force_rtol >= 0.0:
            raise InputError("solver.force_rtol", f"must be >= 0, got {self.force_rtol}")
        if self.max_it < 1:
            raise InputError("solver.max_it", f"must be >= 1, got {self.max_it}")

    def petsc_options(self) -> dict[str, str]:
        """The SNES/KSP options these settings stand for."""
        opts: dict[str, str] = {
            "snes_type": "newtonls",
            "snes_linesearch_type": self.line_search,
            "snes_rtol": str(self.rtol),
            "snes_atol": str(self.atol),
            "snes_stol": "0",
            "snes_max_it": str(self.max_it),
            "snes_max_funcs": "100000",
            # Dirichlet rows of the residual are in mm, the others in N: no divergence test
            "snes_divergence_tolerance": "-1",
        }
        if self.linear_solver == "mumps":
            opts |= {"ksp_type": "preonly", "pc_type": "lu",
                     "pc_factor_mat_solver_type": "mumps"}
        else:
            # GMRES: the foam's non-associated flow makes the tangent unsymmetric
            opts |= {"ksp_type": "gmres", "pc_type": "gamg", "ksp_rtol": "1e-10",
                     "pc_gamg_threshold": "0.01", "mg_levels_ksp_type": "chebyshev",
                     "mg_levels_pc_type": "jacobi"}
        return opts | dict(self.petsc)


@dataclass
class StepResult:
    """Outcome of one Newton solve."""

    converged: bool
    iterations: int
    residuals: list[float]
    reason: str
    seconds: float
    augmentations: int = 0


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
        self.last_augmentations = 0
        self._force_scale = 0.0
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

    # -- step lifecycle ----------------------------------------------------------------
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
        self.last_augmentations = aug
        for b in self._bodies:
            b.invalidate()
        return StepResult(ok, iterations, list(self._residuals), reason,
                          time.perf_counter() - t0, aug)

    def accept(self, u_before: list[np.ndarray], force_scale: float = 0.0) -> None:
        """Remember the step's converged state for the next step.

        Args:
            u_before: Displacement of every body before the step (for the extrapolating
                predictor), in the model's body order.
            force_scale: Largest reaction or tool force of the step [N] (``force_rtol``).
        """
        self._u_prev = u_before
        self._force_scale = force_scale

    def reject(self) -> None:
        """Nothing to undo: the model's snapshot holds the whole state."""

    def history_row(self) -> dict[str, float]:
        """No columns beyond the lifecycle's (augmentations are recorded there)."""
        return {}

    def metrics(self) -> dict:
        """No solver metrics."""
        return {}

    def timing(self) -> dict:
        """No timing beyond the lifecycle's (Newton counts are kept there)."""
        return {}
