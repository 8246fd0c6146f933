"""History columns: their names, built in one place, and how writers contribute them.

Every object that has something to say after a converged step (the stepper, the
solver, the prescribed displacements, each tool contact, each interface, the case's
probe) writes its own columns through :class:`HistoryWriter`. A column written by
two writers is an error (:func:`merge`), never a silent override.

Column names carry their unit: ``_N`` force, ``_mm`` length, ``_mm3`` volume, ``_s``
time, ``_Nmm`` energy. Forces, volumes and energies are those of the whole part: the
step lifecycle scales the model's and the solver's columns by the scene's symmetry
copies (:func:`whole_part`); a case's probe writes whole-part figures itself
(:func:`forming.post.whole`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

AXES = "xyz"


def force_column(tool: str, axis: int) -> str:
    """Force the body exerts on ``tool`` along ``axis`` (0, 1, 2) [N]."""
    return f"force_{tool}_{AXES[axis]}_N"


def reaction_column(key: str) -> str:
    """Reaction force on a face with a prescribed displacement [N]."""
    return f"reaction_{key}_N"


def reaction_key(region: str, axis: int, body: str | None = None) -> str:
    """Key of a reaction: ``<region>_<axis>``, prefixed by the body in a multi-body scene."""
    key = f"{region}_{AXES[axis]}"
    return key if body is None else f"{body}_{key}"


def interface_columns(region: str) -> dict[str, str]:
    """Columns of a skin-core interface, by quantity."""
    return {"penetration": f"penetration_{region}_mm", "slip": f"slip_{region}_mm",
            "normal_force": f"normal_force_{region}_N",
            "stabilisation_force": f"stabilisation_force_{region}_N"}


MAX_PENETRATION = "max_penetration_mm"
STROKE = "stroke_mm"

EXTENSIVE_UNITS = ("_N", "_mm3", "_Nmm")
"""Units of the figures that scale with the part: forces, volumes, energies."""


def whole_part(columns: dict[str, float], copies: int) -> dict[str, float]:
    """Columns of the modelled part as figures of the whole part.

    A quarter model (``copies`` 4) carries a quarter of every force, volume and energy
    (:data:`EXTENSIVE_UNITS`); lengths, angles, strains and counts are the same.
    """
    if copies == 1:
        return dict(columns)
    return {k: copies * v if k.endswith(EXTENSIVE_UNITS) else v for k, v in columns.items()}


class ForceSampler(Protocol):
    """How a solver measures forces for the history.

    A static solver reports the forces of the converged state; a dynamic one reports
    their means over the output interval (docs/theory.md, section 12).
    """

    def tool_force(self, contact) -> np.ndarray:
        """Force a tool contact's body exerts on the tool [N], (3,)."""

    def reaction(self, key: str) -> float:
        """Reaction force on the recorded face ``key`` [N]."""


class HistoryWriter(Protocol):
    """Anything that contributes columns to a history row (collective)."""

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """This writer's columns of the current converged state."""


class DuplicateColumn(RuntimeError):
    """Two writers wrote the same history column."""


def merge(row: dict[str, float], columns: dict[str, float], writer: str,
          owners: dict[str, str]) -> None:
    """Add ``columns`` to ``row`` in place, refusing a column another writer wrote.

    Args:
        row: The row being built.
        columns: The new columns.
        writer: Name of the writer (for the error message).
        owners: Column -> writer of the columns already in ``row`` (updated).

    Raises:
        DuplicateColumn: A column of ``columns`` is already in ``row``.
    """
    for key, value in columns.items():
        if key in owners:
            raise DuplicateColumn(f"history column {key!r} written by both "
                                  f"{owners[key]} and {writer}")
        owners[key] = writer
        row[key] = value
