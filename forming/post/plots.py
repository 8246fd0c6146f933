"""Plots of a run's history (called on rank 0)."""

from __future__ import annotations

from pathlib import Path

from forming.history import force_column
from forming.output import plot_curves


def force_travel_plot(rec, out: Path, column: str, travel: float, copies: int, title: str,
                      label: str = "punch force", name: str = "punch_force.png",
                      xlabel: str = "stroke [mm]", ylabel: str | None = None) -> list[Path]:
    """PNG of a force column against the travel, for the whole part.

    Args:
        rec: The run's recorder.
        out: Output folder.
        column: History column of the force [N] (whole part).
        travel: Travel at load parameter 1 [mm].
        copies: The scene's symmetry copies (stated in the title).
        title: Plot title.
        label: Name of the force.
        name: File name.
        xlabel: Label of the travel axis.
        ylabel: Label of the force axis (default: the label with its unit).
    """
    x = rec.column("t") * travel
    whole = "" if copies == 1 else f" (whole part, {copies} x the model)"
    return [plot_curves(Path(out) / name, [(x, rec.column(column), label, "o-")],
                        xlabel, ylabel or f"{label} [N]", title + whole)]


def punch_force_plot(rec, out: Path, stroke: float, title: str, copies: int) -> list[Path]:
    """PNG of the punch's z force against its stroke, for the whole part."""
    return force_travel_plot(rec, out, force_column("punch", 2), stroke, copies, title)
