"""A job: a scene with how to step it, what to record and what to report."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from forming.errors import InputError
from forming.history import force_column, reaction_column, reaction_key
from forming.scene import Scene
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl

Probe = Callable[..., dict[str, float]]
Metrics = Callable[..., dict]
Plots = Callable[..., list[Path]]
Pictures = Callable[..., list[Path]]


@dataclass(frozen=True)
class Response:
    """The force-travel curve that stands for a run (plotted and compared by solvers).

    Attributes:
        column: History column of the force [N].
        travel: Travel at load parameter 1 [mm] (the curve's abscissa is ``t * travel``).
        scale: Factor on the column (-1 for a reaction); None: 1. History columns hold
            whole-part forces already.
        label: Name of the force in plots.
    """

    column: str
    travel: float = 1.0
    scale: float | None = None
    label: str = "force"

    def curve(self, t: np.ndarray, column: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Travel [mm] and force [N] from the load parameters and the column."""
        scale = 1.0 if self.scale is None else self.scale
        return np.asarray(t) * self.travel, scale * np.asarray(column)


@dataclass(frozen=True)
class Job:
    """A scene with how to step it, what to record and what to report.

    Attributes:
        scene: What is simulated.
        steps: Load-step control.
        newton: Newton and linear-solver settings (implicit solver).
        probe: Extra history columns, ``probe(model) -> dict``, evaluated after every
            converged step (collective).
        metrics: The case's named figures, ``metrics(recorder, model) -> dict``,
            evaluated at the end (collective).
        plots: PNG plots from the history, ``plots(recorder, out) -> paths`` (called on
            rank 0).
        pictures: PNG pictures of the final state, ``pictures(model, out) -> paths``
            (collective: gathers on rank 0); PNGs only, left out with
            ``FORMING_PICTURES=0`` (``--no-pictures``), so no data file may come from it.
        field_every: Write ParaView fields every this many converged steps (and last).
        checkpoint_every: Write a checkpoint (``checkpoint.npz``, for ``--restart``)
            every this many converged steps; 0: none (a stop request still writes one).
        solver: ``"implicit"`` (Newton, load steps) or ``"explicit"`` (central
            differences in time; a step is then an output interval).
        explicit: Settings of the explicit solver.
        response: The run's force-travel curve; None: the first tool's z force (or the
            first reaction) against the travel.
        limits: ``(metric, bound)`` pairs: the run's answer is valid only if each metric
            stays at or below its bound (e.g. a virtual test's curve error); reported in
            ``summary.json`` ``validity`` with the solver's own checks.
        cautions: What the case knows from its own settings that limits its answer
            (e.g. a setting that makes the path depend on round-off); logged and written
            with the run's warnings in ``summary.json``.
    """

    scene: Scene
    steps: StepControl = field(default_factory=StepControl)
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    probe: Probe | None = None
    metrics: Metrics | None = None
    plots: Plots | None = None
    pictures: Pictures | None = None
    field_every: int = 1
    checkpoint_every: int = 10
    solver: Literal["implicit", "explicit"] = "implicit"
    explicit: ExplicitOptions = field(default_factory=ExplicitOptions)
    response: Response | None = None
    limits: tuple[tuple[str, float], ...] = ()
    cautions: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.field_every < 1:
            raise InputError("job.field_every", f"must be >= 1, got {self.field_every}")
        if self.checkpoint_every < 0:
            raise InputError("--checkpoint-every",
                             f"must be >= 0 (0: none), got {self.checkpoint_every}")

    def travel_mm(self) -> float | None:
        """Travel at load parameter 1 [mm] (:meth:`forming.scene.Scene.travel_mm`)."""
        return self.scene.travel_mm()

    def response_or_default(self) -> Response:
        """The job's response (a missing scale is 1), or a default one.

        The default is the first tool's z force, else the first recorded reaction (sign as
        recorded), against the travel (:meth:`travel_mm`; the load parameter if none).
        History columns are whole-part figures, so no symmetry factor enters here.
        """
        if self.response is not None:
            r = self.response
            return r if r.scale is not None else Response(r.column, r.travel, 1.0, r.label)
        travel = self.travel_mm() or 1.0
        if self.scene.tools:
            name = self.scene.tools[0].name
            return Response(force_column(name, 2), travel, 1.0, f"{name} force")
        for d in self.scene.displacements:
            comps = [i for i in (2, 0, 1) if getattr(d, "xyz"[i], None) is not None]
            if d.reaction and comps:
                key = reaction_key(d.region, comps[0],
                                   d.body if len(self.scene.bodies) > 1 else None)
                return Response(reaction_column(key), travel, 1.0, f"reaction {key}")
        raise InputError("response", "the job has no tool and no recorded reaction: give "
                         "Job.response to compare its force")
