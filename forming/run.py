"""One step lifecycle for every solver: advance, predict, solve, accept or roll back, output."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, Protocol

import numpy as np

from forming import compat
from forming.errors import InputError
from forming.log import Progress
from forming.model import Model
from forming.output import Recorder, write_final_shape
from forming.scene import Scene
from forming.solver.explicit import ExplicitOptions, ExplicitSolver
from forming.solver.implicit import ImplicitSolver, NewtonOptions, StepResult
from forming.solver.stepping import StepControl, Stepper, StepTooSmall

log = logging.getLogger(__name__)

Probe = Callable[[Model], dict[str, float]]
Metrics = Callable[[Recorder, Model], dict]
Plots = Callable[[Recorder, Path], list[Path]]
Pictures = Callable[[Model, Path], list[Path]]


@dataclass(frozen=True)
class Response:
    """The force-travel curve that stands for a run (plotted and compared by solvers).

    Attributes:
        column: History column of the force [N].
        travel: Travel at load parameter 1 [mm] (the curve's abscissa is ``t * travel``).
        scale: Factor on the column (symmetry copies, or -1 for a reaction).
        label: Name of the force in plots.
    """

    column: str
    travel: float = 1.0
    scale: float = 1.0
    label: str = "force"

    def curve(self, t: np.ndarray, column: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Travel [mm] and force [N] from the load parameters and the column."""
        return np.asarray(t) * self.travel, self.scale * np.asarray(column)


@dataclass(frozen=True)
class Job:
    """A scene with how to step it, what to record and what to report.

    Attributes:
        scene: What is simulated.
        steps: Load-step control.
        newton: Newton and linear-solver settings.
        probe: Extra history columns, evaluated after every converged step (collective).
        metrics: The case's named figures, evaluated at the end (collective).
        plots: PNG plots from the history (called on rank 0).
        pictures: PNG pictures of the final state (collective: gathers on rank 0).
        field_every: Write ParaView fields every this many converged steps (and last).
        solver: ``"implicit"`` (Newton, load steps) or ``"explicit"`` (central
            differences in time; a step is then an output interval).
        explicit: Settings of the explicit solver.
        response: The run's force-travel curve; None: the first tool's z force (or the
            first reaction) against the load parameter.
    """

    scene: Scene
    steps: StepControl = field(default_factory=StepControl)
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    probe: Probe | None = None
    metrics: Metrics | None = None
    plots: Plots | None = None
    pictures: Pictures | None = None
    field_every: int = 1
    solver: Literal["implicit", "explicit"] = "implicit"
    explicit: ExplicitOptions = field(default_factory=ExplicitOptions)
    response: Response | None = None

    def response_or_default(self) -> Response:
        """The job's response, or the first tool's z force against the load parameter."""
        if self.response is not None:
            return self.response
        if self.scene.tools:
            return Response(f"force_{self.scene.tools[0].name}_z_N",
                            label=f"{self.scene.tools[0].name} force")
        for d in self.scene.displacements:
            comps = [c for c in "zxy" if getattr(d, c) is not None]
            if d.reaction and comps:
                key = f"{d.region}_{comps[0]}"
                if len(self.scene.bodies) > 1:
                    key = f"{d.body}_{key}"
                return Response(f"reaction_{key}_N", label=f"reaction {key}")
        raise InputError("response", "the job has no tool and no recorded reaction: give "
                         "Job.response to compare its force")


class Solver(Protocol):
    """What the step lifecycle needs of a solver (implicit or explicit)."""

    retries_on_failure: bool  # a failed step is cut back and retried
    last_augmentations: int
    assembly_seconds: float

    def predict(self, t_new: float, t_old: float, dt_old: float) -> None:
        """Prepare the step to ``t_new`` (the model's load is already set)."""

    def solve(self) -> StepResult:
        """Take the step."""

    def accept(self, u_before: list, force_scale: float = 0.0) -> None:
        """The step converged and was committed."""

    def reject(self) -> None:
        """The step failed; the model was restored to its snapshot."""

    def history_row(self) -> dict[str, float]:
        """Solver columns of the history row."""

    def metrics(self) -> dict:
        """Solver figures for ``summary.json`` metrics."""

    def timing(self) -> dict:
        """Solver figures for ``summary.json`` timing."""


def make_solver(job: Job, model: Model) -> tuple[Solver, StepControl]:
    """The job's solver for ``model``, and the step control it walks the load with.

    The explicit solver's steps are output intervals of fixed size: the job's largest
    load step, at most 0.02, unless ``explicit.output_interval`` says otherwise.
    """
    if job.solver == "implicit":
        return ImplicitSolver(model, job.newton), job.steps
    if job.solver != "explicit":
        raise ValueError(f"unknown solver {job.solver!r}")
    size = job.explicit.output_interval or min(job.steps.max, 0.02)
    return (ExplicitSolver(model, job.explicit),
            StepControl(initial=size, max=size, min=size, stops=job.steps.stops))


class _Fields:
    """ParaView output: displacement, cell-mean plastic strain, tool surfaces."""

    def __init__(self, model: Model, recorder: Recorder):
        self.model = model
        self.recorder = recorder
        several = len(model.bodies) > 1
        for name, body in model.bodies.items():
            recorder.add_fields(f"displacement_{name}" if several else "displacement", [body.u])
        self.tools = None
        if model.scene.tools:
            # collective (reductions over ranks): on every rank, outside the rank-0 branch
            bounds, resolution = model.tool_bounds(), model.tool_resolution()
            if model.comm.rank == 0:
                from forming.contact.render import ToolSeries

                self.tools = ToolSeries(recorder.out,
                                        [(t.name, t.shape) for t in model.scene.tools],
                                        bounds, resolution)
        self.stems: list[str] = []
        for name, body in model.bodies.items():
            for stem, funcs in body.output_fields().items():
                stem = f"{stem}_{name}" if several else stem
                recorder.add_fields(stem, funcs)
                self.stems.append(stem)

    def write_tools(self, step: int, t: float) -> None:
        if self.tools is not None:
            self.tools.write(step, t, {tl.name: tl.offset(t) for tl in self.model.scene.tools})

    def update(self) -> None:
        for body in self.model.bodies.values():
            body.update_output()


def simulate(job: Job, out: Path, case: str, parameters: dict) -> dict:
    """Run a job through the load programme and write the output contract into ``out``.

    Returns:
        The summary (as written to ``summary.json``).
    """
    t_start = time.perf_counter()
    comm = job.scene.mesh.mesh.comm
    model = Model(job.scene)
    solver, steps = make_solver(job, model)
    jit_s = time.perf_counter() - t_start
    recorder = Recorder(out, comm)
    fields = _Fields(model, recorder)
    stepper = Stepper(steps)
    progress = Progress(case)
    newton_total = 0
    newton_accepted = 0
    status, reason = "completed", ""
    slip_warned: set[str] = set()
    work = "increments" if job.solver == "explicit" else "newton"

    def record(res_its: int, res_norm: float, step_s: float) -> float:
        """Append a history row; return the step's force scale.

        The scale (largest reaction or tool force) feeds the solver's force-scaled
        convergence criterion.
        """
        row: dict[str, float] = {
            "step": stepper.n_accepted, "t": stepper.t, "dt": stepper.last_dt,
            "newton_iterations": res_its, "residual": res_norm, "step_wall_s": step_s,
        }
        row["min_det_F"] = min(b.min_det_F() for b in model.bodies.values())
        reactions = model.dirichlet.reactions(comm)
        row |= {f"reaction_{k}_N": v for k, v in reactions.items()}
        scale = max((abs(v) for v in reactions.values()), default=0.0)
        for c in model.contacts:
            f = c.force()
            scale = max(scale, float(np.linalg.norm(f)))
            row |= {f"force_{c.tool.name}_{'xyz'[i]}_N": f[i] for i in range(3)}
        if model.contacts:
            row["max_penetration_mm"] = max(c.penetration() for c in model.contacts)
        for itf in model.interfaces:
            key = itf.spec.region
            row[f"penetration_{key}_mm"] = itf.penetration()
            slip = itf.max_slip()
            row[f"slip_{key}_mm"] = slip
            row[f"normal_force_{key}_N"] = itf.normal_force()
            if itf.stabilisation is not None:
                row[f"stabilisation_force_{key}_N"] = itf.stabilisation_force()
            if slip > itf.spec.slip_warning * itf.edge and key not in slip_warned:
                slip_warned.add(key)
                log.warning("interface %s: slip %.3g mm exceeds %.2g x the facet edge "
                            "(%.3g mm); the small-sliding pairing loses accuracy from here",
                            key, slip, itf.spec.slip_warning, itf.edge)
        if model.constraints:
            row["augmentations"] = solver.last_augmentations
        row |= solver.history_row()
        if job.probe is not None:
            row |= job.probe(model)
        recorder.record(row)
        return scale

    model.set_load(0.0)
    record(0, 0.0, 0.0)
    fields.update()
    recorder.write_fields(0.0)
    fields.write_tools(0, 0.0)
    written_t = 0.0
    while not stepper.done:
        t_old = stepper.t
        t_new = stepper.propose()
        snap = model.snapshot()
        model.set_load(t_new)
        solver.predict(t_new, t_old, stepper.last_dt)
        res = solver.solve()
        newton_total += res.iterations
        if res.converged:
            model.commit()
            newton_accepted += res.iterations
            stepper.accept(t_new, res.iterations)
            scale = record(res.iterations, res.residuals[-1] if res.residuals else 0.0,
                           res.seconds)
            solver.accept([u for u, _hist in snap["bodies"]], scale)
            log.info("step %d t=%.5f dt=%.3g %s=%d |r|=%.2e %.2fs", stepper.n_accepted,
                     t_new, stepper.last_dt, work, res.iterations,
                     res.residuals[-1] if res.residuals else 0.0, res.seconds)
            progress.update(t_new, f"step {stepper.n_accepted} {work} {res.iterations}")
            if stepper.n_accepted % job.field_every == 0 or stepper.done:
                fields.update()
                recorder.write_fields(t_new)
                fields.write_tools(stepper.n_accepted, t_new)
                written_t = t_new
            continue
        model.restore(snap)
        solver.reject()
        if not solver.retries_on_failure:
            status, reason = "failed", f"at load parameter {t_old:.6g}: {res.reason}"
            log.error("run stopped: %s", reason)
            break
        log.warning("step to t=%.5f failed after %d iterations: %s; cutting back",
                    t_new, res.iterations, res.reason)
        try:
            stepper.reject()
        except StepTooSmall as exc:
            status, reason = "failed", f"{exc}; last failure: {res.reason}"
            log.error("run stopped: %s", reason)
            break
    progress.close()
    if written_t != stepper.t:
        fields.update()
        recorder.write_fields(stepper.t)
        fields.write_tools(stepper.n_accepted, stepper.t)
    recorder.close()

    metrics = job.metrics(recorder, model) if job.metrics is not None else {}
    metrics |= solver.metrics()
    wall_s = time.perf_counter() - t_start
    bodies = list(model.bodies.values())
    summary = {
        "case": case,
        "status": status,
        "reason": reason,
        "load_parameter_reached": stepper.t,
        "metrics": metrics,
        "timing": {
            "wall_s": wall_s, "jit_s": jit_s, "steps": stepper.n_accepted,
            "rejected_steps": stepper.n_rejected, "newton_iterations": newton_total,
            "newton_per_step": newton_accepted / max(stepper.n_accepted, 1),
            "kernel_s": comm.allreduce(sum(b.kernel_seconds for b in bodies)) / comm.size,
            "assembly_s": comm.allreduce(solver.assembly_seconds) / comm.size,
        } | solver.timing(),
        "solver": job.solver,
        "ranks": comm.size,
        "mesh": {"cells": sum(comm.allreduce(b.n_local_cells) for b in bodies),
                 "dofs": sum(b.V.dofmap.index_map.size_global * 3 for b in bodies),
                 "quadrature_points_per_cell": bodies[0].n_points
                 // max(len(bodies[0].cells), 1)},
        "versions": compat.versions(),
        "parameters": parameters,
        "outputs": ["summary.json", "history.csv"]
        + [f"{stem}.bp" for stem in recorder.field_stems()]
        + [f"tool_{t.name}.pvd" for t in job.scene.tools] + ["final_shape.npz"],
    }
    write_final_shape(recorder.out / "final_shape.npz", model.bodies, comm)
    if job.pictures is not None:
        summary["outputs"] += [p.name for p in job.pictures(model, recorder.out)]
    if comm.rank == 0 and job.plots is not None and recorder.rows:
        pngs = job.plots(recorder, recorder.out)
        summary["outputs"] += [p.name for p in pngs]
    recorder.write_summary(summary)
    return summary


def relative_rms(computed: np.ndarray, reference: np.ndarray) -> float:
    """RMS of the difference over the RMS of the reference."""
    ref = np.sqrt(np.mean(np.square(reference)))
    return float(np.sqrt(np.mean(np.square(computed - reference))) / ref) if ref > 0 else np.inf
