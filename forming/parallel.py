"""Reductions over the ranks of a run, in one place.

Each function is collective: every rank must call it, with its own (possibly empty)
share of the values. Calling one inside an ``if rank == 0:`` branch hangs the run.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)


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
