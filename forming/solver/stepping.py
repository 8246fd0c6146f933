"""Adaptive load stepping: propose, accept (grow), reject (cut back)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from forming.errors import InputError


class StepTooSmall(RuntimeError):
    """The step was cut below the minimum step size."""


@dataclass(frozen=True)
class StepControl:
    """Load-step settings, as fractions of the load parameter range [0, 1].

    Attributes:
        initial: First step size.
        max: Largest step size.
        min: Smallest step size before the run stops.
        grow: Growth factor after an easy step.
        cut: Reduction factor after a failed step.
        easy_iterations: A step that converged in at most this many Newton
            iterations counts as easy.
        stops: Load-parameter values every run must land on (output points).
    """

    initial: float = 0.05
    max: float = 0.1
    min: float = 1e-5
    grow: float = 1.5
    cut: float = 0.5
    easy_iterations: int = 4
    stops: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name in ("initial", "max", "min"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0 < v <= 1):
                raise InputError(f"steps.{name}", f"must lie in (0, 1], got {v!r}")
        if not self.min <= self.initial <= self.max:
            raise InputError("steps.initial", "must lie between steps.min and steps.max")
        if not self.grow >= 1:
            raise InputError("steps.grow", f"must be >= 1, got {self.grow!r}")
        if not 0 < self.cut < 1:
            raise InputError("steps.cut", f"must lie in (0, 1), got {self.cut!r}")
        if any(not 0 < s < 1 for s in self.stops):
            raise InputError("steps.stops", "must lie strictly between 0 and 1")


@dataclass(frozen=True)
class StepperState:
    """Where a :class:`Stepper` stands (for checkpoints)."""

    t: float
    dt: float
    last_dt: float
    n_accepted: int
    n_rejected: int


class Stepper:
    """Walks the load parameter from 0 to 1 with adaptive steps.

    Args:
        control: The step settings.
    """

    def __init__(self, control: StepControl):
        self.control = control
        self.t = 0.0
        self.dt = control.initial
        self.last_dt = 0.0
        self.n_accepted = 0
        self.n_rejected = 0
        self._stops = sorted(set(control.stops) | {1.0})

    @property
    def done(self) -> bool:
        """True once the load parameter reached 1."""
        return self.t >= 1.0 - 1e-12

    def propose(self) -> float:
        """Next load parameter, landing exactly on the next stop."""
        nxt = next(s for s in self._stops if s > self.t + 1e-12)
        t_new = self.t + self.dt
        # land on a stop, and avoid leaving a sliver smaller than a quarter step
        if t_new >= nxt - 0.25 * self.dt:
            t_new = nxt
        return t_new

    def accept(self, t_new: float, iterations: int) -> None:
        """Record a converged step and grow the step after an easy one."""
        self.last_dt = t_new - self.t
        self.t = t_new
        self.n_accepted += 1
        if iterations <= self.control.easy_iterations:
            self.dt = min(self.dt * self.control.grow, self.control.max)

    def reject(self) -> None:
        """Cut the step back.

        Raises:
            StepTooSmall: The new step would be smaller than ``control.min``.
        """
        self.n_rejected += 1
        self.dt *= self.control.cut
        if self.dt < self.control.min * (1 - 1e-9):
            raise StepTooSmall(
                f"step cut below the minimum {self.control.min:g} at load parameter {self.t:.6g}"
            )

    def resume(self, dt: float) -> None:
        """Go on with step size ``dt`` (within the control's bounds) after a change of model."""
        self.dt = min(max(dt, self.control.min), self.control.max)

    def state(self) -> StepperState:
        """Where the stepper stands."""
        return StepperState(self.t, self.dt, self.last_dt, self.n_accepted, self.n_rejected)

    def restore(self, state: StepperState) -> None:
        """Return to a state."""
        self.t, self.dt, self.last_dt = state.t, state.dt, state.last_dt
        self.n_accepted, self.n_rejected = state.n_accepted, state.n_rejected
