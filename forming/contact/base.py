"""What the model and the solvers need of a constraint between a body and something else.

Tool contacts (:class:`~forming.contact.terms.ContactTerm`) and skin-core interfaces
(:class:`~forming.contact.interface.InterfaceTerm`) both implement
:class:`Constraint`; a new kind (finite sliding, a tie) plugs in the same way.
"""

from __future__ import annotations

from typing import Protocol

import ufl

from forming.history import ForceSampler

PENALTY_FACTOR = 10.0  # the default penalty is this many times a surface layer's stiffness


def default_penalty(stiffness: float, edge: float, thickness: float,
                    penalty_only: bool) -> float:
    """The default normal penalty of a body's contact with a rigid tool [N/mm^3].

    With multipliers (augmented Lagrangian, implicit runs) the answer does not depend on
    the penalty, which is chosen for Newton's sake: ``10 E / h``, ``E`` the body's
    through-thickness modulus and ``h`` the smallest edge of the contact surface. With
    the penalty alone (explicit runs) it sets the answer, the penetration ``p / eps``: it
    is then ten times the stiffness of the body's layer through its thickness,
    ``10 E / min(h, t)``, so that the penetration is a tenth of what the pressure
    compresses the layer by. The two agree for a body thicker than its elements are
    wide. On the hemisphere's 0.4 mm skins under 18.75 mm elements ``10 E / h`` let the
    punch sink 0.5 mm into a skin, and the explicit punch force was 24% low
    (docs/validation.md, "Finite sliding: the hemisphere with skins").

    Contacts between two deformable bodies keep ``10 E / h`` in either solver: between
    a skin and the core the thin-layer penalty made the explicit sled chatter (its
    friction ratio swung between 0.40 and 1.14 where it held 0.49-0.52).

    Args:
        stiffness: The body's through-thickness modulus [MPa].
        edge: Smallest edge of the contact surface [mm].
        thickness: The body's smallest extent [mm].
        penalty_only: Whether the contact is enforced by the penalty alone.
    """
    length = min(edge, thickness) if penalty_only else edge
    return PENALTY_FACTOR * stiffness / length


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
