"""Run a job to the end of its load programme: the loop around the step API."""

from __future__ import annotations

from pathlib import Path

from forming import signals
from forming.job import Job
from forming.simulation import Simulation


def simulate(job: Job, out: Path, case: str, parameters: dict,
             assignments: list[str] | None = None, restart: bool = False) -> dict:
    """Run a job through the load programme and write the output contract into ``out``.

    SIGINT and SIGTERM stop the run at its last converged state (status
    ``interrupted``, the signal in ``summary["signal"]``) instead of killing it, and
    leave a checkpoint of that state (``checkpoint.npz``).

    Args:
        job: What to run.
        out: Output folder.
        case: Name of the case.
        parameters: The case's parameters (recorded).
        assignments: The ``--set`` items the job was built from (recorded, for a restart).
        restart: Continue the run in ``out`` from its checkpoint
            (:class:`~forming.simulation.Simulation`).

    Returns:
        The summary (as written to ``summary.json``).
    """
    with signals.catch_stops():
        sim = None
        try:
            sim = Simulation(job, Path(out), case, parameters, assignments, restart)
            return sim.run()
        finally:
            if sim is not None:  # collective: every rank here, whatever the garbage collector
                sim.solver.close()
            signals.clear()
