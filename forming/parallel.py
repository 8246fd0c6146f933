"""Reductions over the ranks of a run, in one place.

Each function is collective: every rank must call it, with its own (possibly empty)
share of the values. Calling one inside an ``if rank == 0:`` branch hangs the run.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.errors import InputError


def on_root[T](comm: MPI.Comm, work: Callable[[], T],
               gmsh_field: str | None = None) -> T | None:
    """Run ``work`` on rank 0 alone; an error there is raised on every rank (collective).

    Meshing and file reading happen on rank 0 while the other ranks wait for its mesh in
    a collective call: an error raised on rank 0 alone would leave them waiting forever.
    Here it is sent to every rank and raised there: an :class:`InputError` as itself
    (its field and message; the exception object does not pickle), a bare ``Exception``
    (what gmsh raises) as an :class:`InputError` of ``gmsh_field`` if given, anything
    else as a ``RuntimeError`` that names it.

    Returns:
        ``work``'s result on rank 0, None on the other ranks.
    """
    result, failure, cause = None, None, None
    if comm.rank == 0:
        try:
            result = work()
        except InputError as exc:
            failure, cause = (exc.field, str(exc).removeprefix(f"{exc.field}: ")), exc
        except Exception as exc:
            if gmsh_field is not None and type(exc) is Exception:
                failure = (gmsh_field, f"gmsh failed: {exc}")
            else:
                failure = (None, f"{exc!r} on rank 0")
            cause = exc
    failure = comm.bcast(failure, root=0)
    if failure is None:
        return result
    if failure[0] is None:
        raise RuntimeError(failure[1]) from cause
    raise InputError(*failure) from cause


def global_max(comm: MPI.Comm, values, initial: float = -np.inf) -> float:
    """Largest of every rank's values (``initial`` where no rank has any)."""
    return comm.allreduce(float(np.max(values, initial=initial)), op=MPI.MAX)


def global_min(comm: MPI.Comm, values, initial: float = np.inf) -> float:
    """Smallest of every rank's values (``initial`` where no rank has any)."""
    return comm.allreduce(float(np.min(values, initial=initial)), op=MPI.MIN)


def global_sum(comm: MPI.Comm, values) -> float:
    """Sum of every rank's values."""
    return comm.allreduce(float(np.sum(values)), op=MPI.SUM)


def global_count(comm: MPI.Comm, mask) -> int:
    """Number of true entries of every rank's mask."""
    return comm.allreduce(int(np.count_nonzero(mask)), op=MPI.SUM)


def global_mean(comm: MPI.Comm, values, empty: float = 0.0) -> float:
    """Mean of every rank's values (``empty`` where no rank has any)."""
    n = global_count(comm, np.ones(np.shape(values), dtype=bool))
    return global_sum(comm, values) / n if n else empty


def assemble_scalar(form: fem.Form) -> float:
    """A compiled scalar form assembled and summed over the ranks of its mesh."""
    comm = form.mesh.comm
    return comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


def peak_rss_mb(comm: MPI.Comm) -> float:
    """Peak resident memory of the process, the largest over the ranks [MB].

    ``getrusage``'s ``ru_maxrss`` (kilobytes on Linux): the high-water mark of the whole
    process since it started, set-up and compilation included.
    """
    import resource

    local = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return comm.allreduce(local, op=MPI.MAX)
