"""Errors raised for bad input and for failures inside a solve."""

from __future__ import annotations


class InputError(ValueError):
    """Invalid user input; the message names the offending field.

    Args:
        field: Dotted name of the field (``"material.curve.strain"``, ``"mesh.path"``).
        message: What is wrong and what would be valid.
    """

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field


class KernelFailure(RuntimeError):
    """A quadrature-point kernel failed (inverted element or return mapping).

    Raised inside a solve; the solver turns it into a failed step, which the step
    lifecycle cuts back (implicit) or reports (explicit).
    """


class SolveFailure(RuntimeError):
    """A solve outside the step lifecycle (an eigenvalue analysis, say) did not succeed."""


EXIT_CODES = {
    "completed": 0,
    "failed": 1,  # a solve that did not converge, or a case's code that raised
    "input": 2,  # bad input: an unknown case or parameter, a bad value, a used folder
    "io": 3,  # a file or folder that cannot be read or written
    "internal": 4,  # an unexpected error (a bug: please report it)
    "SIGINT": 130,  # interrupted by Ctrl-C: the last converged state is on disk
    "SIGTERM": 143,  # stopped by a scheduler: the last converged state is on disk
}
"""Exit codes of ``forming run`` and the case scripts (README, "Exit codes")."""
