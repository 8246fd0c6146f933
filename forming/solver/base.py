"""What the step lifecycle needs of a solver, and what a step returns.

The lifecycle (:class:`~forming.simulation.Simulation`) walks the load parameter from 0
to 1 in steps; for each it asks the solver to advance, solve, and then accept or roll
back. It never asks which solver it has: the solver owns how the load is applied (at
once for a static Newton step, increment by increment in explicit dynamics), its
predictor, the name of its unit of work, and how it samples forces for the history.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from forming.solver.stepping import StepControl


@dataclass
class StepResult:
    """Outcome of one attempted step.

    Attributes:
        converged: The step reached equilibrium (implicit) or stayed stable (explicit).
        work: Units of work spent (Newton iterations or time increments, see
            :attr:`Solver.work_name`).
        residuals: Residual norms of the Newton iterations (empty for explicit).
        reason: Why the step failed (or the solver's convergence reason).
        seconds: Wall time of the step.
        augmentations: Multiplier updates of the contact constraints (Uzawa passes).
        final: The step failed in a way a smaller step cannot cure: the run stops at
            the last converged state.
        control_work: The work the step size is judged by, where it is not all of
            ``work`` (the implicit solver's second solve with relaxed springs); None:
            ``work``.
    """

    converged: bool
    work: int
    residuals: list[float] = field(default_factory=list)
    reason: str = ""
    seconds: float = 0.0
    augmentations: int = 0
    final: bool = False
    control_work: int | None = None

    @property
    def residual(self) -> float:
        """The last residual norm (0 when the solver has none)."""
        return self.residuals[-1] if self.residuals else 0.0


class Solver(Protocol):
    """A solver the step lifecycle can drive (implicit Newton or explicit dynamics).

    Attributes:
        kind: ``"implicit"`` or ``"explicit"`` (recorded in ``summary.json``).
        work_name: What :attr:`StepResult.work` counts, e.g. ``"Newton iterations"``.
        work_column: History column of the work per step.
        retries_on_failure: A failed step may be cut back and retried.
    """

    kind: str
    work_name: str
    work_column: str
    retries_on_failure: bool

    def step_control(self, requested: StepControl) -> StepControl:
        """The step control the lifecycle walks the load with (from the job's)."""

    def advance(self, t_old: float, t_new: float, dt_old: float) -> None:
        """Prepare the step from ``t_old`` to ``t_new``: apply the load, predict."""

    def solve(self) -> StepResult:
        """Take the step."""

    def accept(self, force_scale: float) -> None:
        """The step converged and the model committed it.

        Args:
            force_scale: Largest tool or reaction force of the step [N] (a Newton
                solver scales its residual tolerance by it).
        """

    def snapshot(self) -> object:
        """Copy of the solver's own state (predictor, velocities, energies)."""

    def restore(self, snap: object) -> None:
        """Return to a snapshot (after a failed step, or to restart)."""

    def snapshot_layout(self) -> object:
        """The snapshot's structure with a layout for each array over a mesh, else None.

        See :meth:`forming.bodies.base.DeformableBody.snapshot_layout`.
        """

    def tool_force(self, contact) -> np.ndarray:
        """Force of a contact's body on its tool as reported in the history [N]."""

    def reaction(self, key: str) -> float:
        """Reaction on a recorded face as reported in the history [N]."""

    def history_columns(self, result: StepResult) -> dict[str, float]:
        """The solver's columns of the history row of an accepted step."""

    def metrics(self) -> dict:
        """Solver figures for ``summary.json`` metrics."""

    def timing(self) -> dict:
        """Solver figures for ``summary.json`` timing (its work counter included)."""

    def parameters(self) -> dict:
        """Its settings, recorded in ``summary.json`` parameters."""

    def validity(self) -> dict[str, bool]:
        """Checks that the run's answer means what it should (e.g. quasi-static)."""

    def warnings(self) -> list[str]:
        """What a user should know about the run (collective)."""

    def close(self) -> None:
        """Release what the ranks hold together, on every rank at the same point.

        A PETSc solver's destruction is collective (MUMPS ends its instance on all
        ranks). Left to garbage collection, one rank may free it at once and another
        only in a reference cycle's later collection: the first then waits for ever.
        """
