"""Rank-0 logging and a terminal progress line."""

from __future__ import annotations

import logging
import sys

from mpi4py import MPI


def setup(level: int = logging.INFO) -> None:
    """Log to stderr on rank 0 only; other ranks log warnings and errors."""
    root = logging.getLogger("forming")
    if root.handlers:
        return
    handler = logging.StreamHandler(sys.stderr)
    rank = MPI.COMM_WORLD.rank
    prefix = "" if MPI.COMM_WORLD.size == 1 else f"[{rank}] "
    handler.setFormatter(logging.Formatter(f"{prefix}%(levelname)s %(name)s: %(message)s"))
    root.addHandler(handler)
    root.setLevel(level if rank == 0 else logging.WARNING)
    root.propagate = False


class Progress:
    """A one-line progress bar on an interactive terminal (rank 0); silent otherwise."""

    def __init__(self, label: str):
        self.label = label
        self.active = MPI.COMM_WORLD.rank == 0 and sys.stderr.isatty()

    def update(self, t: float, text: str) -> None:
        """Redraw the bar at load parameter ``t`` in [0, 1]."""
        if not self.active:
            return
        n = int(30 * min(max(t, 0.0), 1.0))
        sys.stderr.write(f"\r{self.label} [{'#' * n}{'.' * (30 - n)}] {100 * t:5.1f}% {text}   ")
        sys.stderr.flush()

    def close(self) -> None:
        """End the progress line."""
        if self.active:
            sys.stderr.write("\n")
            sys.stderr.flush()
