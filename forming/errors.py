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
