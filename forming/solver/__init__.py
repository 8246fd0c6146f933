"""Solvers and the step lifecycle they share.

A solver implements :class:`~forming.solver.base.Solver`; :func:`make_solver` is the
only place that knows which solver a job asks for. A new solver registers its builder in
:data:`SOLVERS`.
"""

from __future__ import annotations

from collections.abc import Callable

from forming.errors import InputError
from forming.solver.base import Solver, StepResult
from forming.solver.options import ExplicitOptions, NewtonOptions

__all__ = ["PENALTY_ONLY", "SOLVERS", "ExplicitOptions", "NewtonOptions", "Solver",
           "StepResult", "make_solver", "penalty_only"]


def _implicit(model, job) -> Solver:
    from forming.solver.implicit import ImplicitSolver

    return ImplicitSolver(model, job.newton)


def _explicit(model, job) -> Solver:
    from forming.solver.explicit import ExplicitSolver

    return ExplicitSolver(model, job.explicit)


SOLVERS: dict[str, Callable] = {"implicit": _implicit, "explicit": _explicit}


# the solvers that enforce contact by the penalty alone (no multipliers): the model's
# default penalties follow (forming.contact.base.default_penalty)
PENALTY_ONLY: frozenset[str] = frozenset({"explicit"})


def _known(job) -> str:
    if job.solver not in SOLVERS:
        raise InputError("solver", f"must be one of {sorted(SOLVERS)}, got {job.solver!r}")
    return job.solver


def penalty_only(job) -> bool:
    """Whether the solver ``job.solver`` enforces contact by the penalty alone.

    Raises:
        InputError: Unknown solver name.
    """
    return _known(job) in PENALTY_ONLY


def make_solver(job, model) -> Solver:
    """The solver a job asks for (``job.solver``), built for ``model``.

    Raises:
        InputError: Unknown solver name.
    """
    return SOLVERS[_known(job)](model, job)
