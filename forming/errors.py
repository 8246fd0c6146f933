"""Errors raised for bad input and failed solves."""

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


class SolveFailed(RuntimeError):
    """A solve stopped before the end of the loading programme."""
