"""Rank-0 logging and the progress of a run.

On a terminal a run shows one updating progress line (stroke, step, time per step,
estimated time left) with log messages printed above it; elsewhere (a file, a batch
job) every step is a plain log line. ``quiet`` keeps warnings and errors only.
"""

from __future__ import annotations

import logging
import sys
import time

from mpi4py import MPI

_LINE = {"text": ""}  # the progress line currently shown (rank 0, terminal only)


def collective_warning(logger: logging.Logger, msg: str, *args) -> None:
    """Log a warning that every rank reaches with the same text, once: on rank 0.

    Other ranks keep logging their own warnings (:func:`setup`); this is for those of a
    collective decision (a step cut back, a run's closing cautions), which would
    otherwise be printed once per rank.
    """
    if MPI.COMM_WORLD.rank == 0:
        logger.warning(msg, *args)


class _AboveProgress(logging.StreamHandler):
    """A stream handler that prints above the progress line and redraws it."""

    def emit(self, record: logging.LogRecord) -> None:
        if _LINE["text"]:
            self.stream.write("\r\033[K")
        super().emit(record)
        if _LINE["text"]:
            self.stream.write(_LINE["text"])
            self.flush()


def setup(level: int = logging.INFO, quiet: bool = False) -> None:
    """Log to stderr on rank 0 only; other ranks log warnings and errors.

    Args:
        level: Level of rank 0.
        quiet: Warnings and errors only, no progress line.
    """
    root = logging.getLogger("forming")
    rank = MPI.COMM_WORLD.rank
    root.setLevel(logging.WARNING if quiet or rank != 0 else level)
    Progress.enabled = not quiet
    if root.handlers:
        return
    handler = _AboveProgress(sys.stderr)
    prefix = "" if MPI.COMM_WORLD.size == 1 else f"[{rank}] "
    handler.setFormatter(logging.Formatter(f"{prefix}%(levelname)s %(name)s: %(message)s"))
    root.addHandler(handler)
    root.propagate = False


class Progress:
    """Progress of a run: an updating terminal line on rank 0, else log lines.

    Args:
        label: Name shown on the line (the case).
        travel: Travel at load parameter 1 [mm] (None: the load parameter is shown).
        log: Logger of the plain lines.
    """

    enabled = True

    def __init__(self, label: str, travel: float | None = None,
                 log: logging.Logger | None = None):
        self.label = label
        self.travel = travel
        self.log = log or logging.getLogger("forming.simulation")
        self.terminal = (self.enabled and MPI.COMM_WORLD.rank == 0 and sys.stderr.isatty()
                         and self.log.isEnabledFor(logging.INFO))
        self._t0 = time.perf_counter()

    def where(self, t: float) -> str:
        """The state ``t`` as a user reads it: the stroke in mm, or the load parameter."""
        if self.travel is None:
            return f"load {t:.4f}"
        return f"stroke {t * self.travel:.4g} mm"

    def step(self, n: int, t: float, dt: float, work: str, seconds: float) -> None:
        """Report an accepted step ``n`` that reached load parameter ``t``."""
        if not self.terminal:
            self.log.info("step %d %s (t=%.5f, dt=%.3g) %s %.2fs", n, self.where(t), t, dt,
                          work, seconds)
            return
        elapsed = time.perf_counter() - self._t0
        left = elapsed * (1.0 - t) / t if t > 0 else float("inf")
        bar = "#" * int(20 * min(max(t, 0.0), 1.0))
        _LINE["text"] = (f"{self.label} [{bar:<20}] {100 * t:5.1f}% {self.where(t)}, step {n}"
                         f" ({seconds:.2f} s, {work}), about {_duration(left)} left")
        sys.stderr.write("\r\033[K" + _LINE["text"])
        sys.stderr.flush()

    def close(self) -> None:
        """End the progress line."""
        if self.terminal and _LINE["text"]:
            sys.stderr.write("\n")
            sys.stderr.flush()
        _LINE["text"] = ""


def _duration(seconds: float) -> str:
    if seconds == float("inf"):
        return "?"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
