"""What the model and the solvers need of a constraint between a body and something else.

Tool contacts (:class:`~forming.contact.terms.ContactTerm`) and skin-core interfaces
(:class:`~forming.contact.interface.InterfaceTerm`) both implement
:class:`Constraint`; a new kind (finite sliding, a tie) plugs in the same way.
"""

from __future__ import annotations

from typing import Protocol

import ufl

from forming.history import ForceSampler


class Constraint(Protocol):
    """An augmented-Lagrangian constraint that adds tractions to one or more bodies.

    Attributes:
        name: Name used in history columns and messages.
        bodies: Names of the bodies it acts on.
        tolerance: Admissible constraint violation [mm].
        penalty: Penalty [N/mm^3].
        friction: Coulomb coefficient (0: frictionless).
    """

    name: str
    bodies: tuple[str, ...]
    tolerance: float
    penalty: float
    friction: float

    def residuals(self, tests: dict) -> dict[str, ufl.Form]:
        """Virtual work of its tractions on each of its bodies, tested with ``tests[name]``."""

    def stiffness_estimate(self, tests: dict) -> dict[str, ufl.Form]:
        """Per body, a vector form bounding its nodal stiffness (explicit time step)."""

    def set_load(self, t: float) -> None:
        """Apply the load programme at load parameter ``t`` (a tool moves)."""

    def track(self) -> None:
        """Follow the current configuration (closest points on a surface mesh).

        Called before every residual and Jacobian; a constraint whose geometry is a UFL
        expression has nothing to do.
        """

    def violation(self) -> float:
        """Constraint violation of the current solution [mm]."""

    def augment(self) -> None:
        """Update the multipliers from the current solution (Uzawa)."""

    def commit(self) -> None:
        """Accept the converged step."""

    def snapshot(self) -> tuple:
        """Copy of the multipliers and history."""

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""

    def snapshot_layout(self) -> tuple:
        """The snapshot's structure with a layout for each array over a mesh, else None.

        See :meth:`forming.bodies.base.DeformableBody.snapshot_layout`.
        """

    def penetration(self) -> float:
        """Largest penetration of the current state [mm]."""

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """Its history columns."""

    def warnings(self) -> list[str]:
        """Warnings raised so far (each once)."""
