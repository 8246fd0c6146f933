"""Stiffening the interfaces' stabilising springs where a load step cannot be cut further.

An interface or sliding pair with ``stabilisation > 0`` carries a weak spring on each
node's motion within a load step (Abaqus' contact stabilisation): it gives a skin that
lifts off, or a node that opens and closes, some stiffness. The weaker the spring, the
smaller its drag on the answer, and the likelier that Newton cycles between two active
sets at a node near zero pressure, however small the step (the 12 x 12 x 3 hemisphere with
skins and no holder at 1e-4 of the penalty: residuals alternating 1.0e-2 and 3.3e-2 for
25 iterations at every step size down to the minimum, docs/theory.md section 11).

Where that happens the run need not stop. As Abaqus/Standard's adaptive automatic
stabilisation raises its damping for increments that fail to converge, a
:class:`SpringEscalation` multiplies every spring by ``factor`` once the step has been cut
below its minimum, and the step is retried at the last accepted size; after ``hold``
accepted steps the springs step back down by one factor, until they are back at their
setting. Up to ``limit`` times the setting; past it the run stops as before. A run that
never reaches the minimum step is not touched. Each change is logged, the spring's scale
is a history column (``spring_scale``), and a run that used it says so in its warnings:
its answer over the stiffened steps carries more of the springs' drag (the
``*_stabilisation_N`` columns).

The drag is the springs' price: a spring stiff enough to carry Newton through a step
also holds the skins back on every step (on the 60 mm demonstrator, 1e-3 of the penalty
put the implicit answer 4.2% of the thickness from the explicit one, 1e-4 put it 2.0%;
docs/validation.md), and a spring weak enough not to drag fails where the first is
needed. A :class:`SpringRelease` takes both: once a step has converged, Newton solves it
again from there with the springs at a fraction of what it converged with. Started from
the converged state, that solve converges where a step begun with the weak spring need
not; where it does not, the step keeps its first answer.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Protocol

log = logging.getLogger(__name__)


class Sprung(Protocol):
    """A constraint with a stabilising spring (interface and sliding pairs)."""

    name: str
    has_spring: bool
    spring_scale: float  # the scale last set

    def scale_spring(self, scale: float) -> None:
        """Set the spring to ``scale`` times its setting."""


class SpringEscalation:
    """Stiffens the springs of a model's pairs when a step cannot be cut further.

    Args:
        pairs: The model's interface and sliding pairs; those with a spring take part.
        factor: Stiffening factor per escalation (1: never stiffen).
        limit: Largest scale over the springs' settings.
        hold: Accepted steps after which the scale steps back down by ``factor``.
    """

    def __init__(self, pairs: list, factor: float, limit: float, hold: int):
        self.pairs: list[Sprung] = [c for c in pairs if c.has_spring]
        self.factor = factor
        self.limit = limit
        self.hold = hold
        self.scale = 1.0
        self.held = 0
        self.events: list[tuple[float, float]] = []  # (load parameter, new scale)
        self.stiffened_steps = 0

    @property
    def active(self) -> bool:
        """Whether the model has springs to stiffen and stiffening is on."""
        return bool(self.pairs) and self.factor > 1.0

    def stiffen(self, t: float) -> float | None:
        """Stiffen the springs by one factor at load parameter ``t``.

        Returns:
            The new scale, or None when there is no spring or the limit is reached.
        """
        new = self.scale * self.factor
        if not self.active or new > self.limit * (1.0 + 1e-9):
            return None
        self._set(new, t)
        return new

    def commit(self, t: float) -> None:
        """An accepted step at load parameter ``t``: count it, step down after ``hold``."""
        if self.scale <= 1.0:
            return
        self.stiffened_steps += 1
        self.held += 1
        if self.held >= self.hold:
            self._set(max(1.0, self.scale / self.factor), t)
            log.info("stabilising springs back to %g times their setting", self.scale)

    def _set(self, scale: float, t: float) -> None:
        self.scale, self.held = scale, 0
        self.events.append((t, scale))
        for c in self.pairs:
            c.scale_spring(scale)

    def history_columns(self) -> dict[str, float]:
        """``spring_scale``, for a model whose springs may be stiffened."""
        return {"spring_scale": self.scale} if self.active else {}

    def state(self) -> dict:
        """What a checkpoint keeps (plain numbers)."""
        return {"scale": self.scale, "held": self.held, "events": [list(e) for e in self.events],
                "stiffened_steps": self.stiffened_steps}

    def restore(self, state: dict | None) -> None:
        """Return to a :meth:`state` (None: a checkpoint from before this existed)."""
        state = state or {"scale": 1.0, "held": 0, "events": [], "stiffened_steps": 0}
        self.held = int(state["held"])
        self.events = [(float(t), float(s)) for t, s in state["events"]]
        self.stiffened_steps = int(state["stiffened_steps"])
        self.scale = float(state["scale"])
        for c in self.pairs:
            c.scale_spring(self.scale)

    def _rises(self) -> list[tuple[float, float]]:
        """The events that stiffened the springs (load parameter, new scale)."""
        before = [1.0, *(sc for _t, sc in self.events)]
        return [(t, sc) for (t, sc), b in zip(self.events, before[:-1], strict=True) if sc > b]

    def summary(self) -> dict:
        """What ``summary.json`` reports (``timing``-like counters)."""
        if not self.active:
            return {}
        return {"spring_escalations": len(self._rises()),
                "spring_scale_max": max((sc for _t, sc in self.events), default=1.0),
                "spring_stiffened_steps": self.stiffened_steps}

    def warnings(self, where) -> list[str]:
        """The run's warning if the springs were stiffened (``where(t)`` names a point)."""
        if not (ups := self._rises()):
            return []
        names = ", ".join(c.name for c in self.pairs)
        return [f"stabilising springs of {names} stiffened {len(ups)} time(s) (first at "
                f"{where(ups[0][0])}, up to {max(sc for _t, sc in ups):g} times their "
                f"setting) where the step could not be cut further; {self.stiffened_steps} "
                "step(s) ran stiffened and carry more of the springs' drag (history: "
                "spring_scale, *_stabilisation_N)"]


class SpringRelease:
    """The implicit solver's second solve of a converged step, with the springs relaxed.

    Args:
        pairs: The model's interface and sliding pairs; those with a spring take part.
        fraction: The springs of the step's answer over those it converged with, in
            (0, 1]; 1: no second solve.
    """

    def __init__(self, pairs: list, fraction: float):
        self.pairs: list[Sprung] = [c for c in pairs if c.has_spring]
        self.fraction = fraction
        self.solves = 0
        self.kept = 0

    @property
    def active(self) -> bool:
        """Whether converged steps are solved again."""
        return bool(self.pairs) and self.fraction < 1.0

    @contextmanager
    def relaxed(self) -> Iterator[None]:
        """The springs at :attr:`fraction` of their present scale, inside the block."""
        scales = [c.spring_scale for c in self.pairs]
        try:
            for c, s in zip(self.pairs, scales, strict=True):
                c.scale_spring(s * self.fraction)
            yield
        finally:
            for c, s in zip(self.pairs, scales, strict=True):
                c.scale_spring(s)

    def record(self, converged: bool, reason: str) -> bool:
        """Count a second solve; returns ``converged`` (True: its answer is kept)."""
        self.solves += 1
        self.kept += int(converged)
        if not converged:
            log.debug("relaxed springs: no convergence (%s); the step keeps its answer",
                      reason)
        return converged

    def summary(self) -> dict:
        """What ``summary.json`` reports under ``timing`` (nothing when inactive)."""
        if not self.active:
            return {}
        return {"spring_release": self.fraction, "spring_release_solves": self.solves,
                "spring_release_kept": self.kept}
