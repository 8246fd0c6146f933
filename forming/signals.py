"""Stop requests: SIGINT and SIGTERM end a run cleanly at its next safe point.

PETSc installs its own signal handler when it starts, which swallows Ctrl-C inside a
solve and leaves the solver in an error state (PETSc error 73); :mod:`forming.compat`
removes it. :func:`catch_stops` installs a handler that only records the request; the
solvers
check it in their callbacks (a Newton step in progress is abandoned and rolled back) and
the step lifecycle between steps, so the run stops at the last converged state, writes
its output and says ``interrupted`` (docs/architecture.md).

The request is per process; the checks that act on it reduce it over the ranks, so
every rank stops at the same point.
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator

from mpi4py import MPI

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}

_requested: int | None = None


def _record(signum, frame) -> None:  # noqa: ARG001
    global _requested
    if _requested is None:
        _requested = signum


def requested() -> int | None:
    """The signal number of a stop request on this rank, or None."""
    return _requested


def requested_anywhere(comm: MPI.Comm) -> int | None:
    """The stop request of any rank (collective), or None."""
    return comm.allreduce(_requested or 0, op=MPI.MAX) or None


def clear() -> None:
    """Forget a stop request (the run that saw it has stopped)."""
    global _requested
    _requested = None


def signal_name(signum: int) -> str:
    """``"SIGINT"`` for 2, and so on."""
    return signal.Signals(signum).name


@contextlib.contextmanager
def catch_stops() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM record a stop request instead of killing.

    The previous Python handlers come back afterwards. Only the main thread can install
    handlers; elsewhere the block changes nothing.
    """
    from forming import compat  # noqa: F401  (removes PETSc's own handler)

    try:
        previous = {s: signal.signal(s, _record) for s in STOP_SIGNALS}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
