"""The step API: one lifecycle for every solver, driven step by step or as a loop.

A :class:`Simulation` owns a model, its solver, the load stepper and the run's output.
Each :meth:`Simulation.step` is one attempt at the next load step: the solver advances
and solves; a converged step is committed, recorded and (every ``field_every`` steps)
written; a failed one is rolled back and cut (or, for a solver that does not retry,
ends the run; one that cannot be cut further first stiffens the interfaces' springs,
:mod:`forming.springs`). :meth:`Simulation.run` is the loop that :func:`forming.run.simulate`
calls; a driver (the blank optimiser, a study, a coupled code) calls :meth:`step` until
a condition of its own, reads :attr:`Simulation.model`, and calls :meth:`finish`.

    sim = Simulation(job, out, "hemisphere")
    while not sim.done and sim.t < 0.5:
        sim.step()
    summary = sim.finish()

:meth:`Simulation.checkpoint` holds the state in memory; :meth:`Simulation.save_checkpoint`
writes it to ``out/checkpoint.npz`` (every ``job.checkpoint_every`` steps, and when a stop
request ends the run), and ``Simulation(job, out, ..., restart=True)`` resumes from it, on
any number of ranks (:mod:`forming.restart`).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forming import compat, provenance, signals
from forming import restart as disk
from forming.errors import InputError
from forming.history import STROKE, force_column, merge, reaction_column, whole_part
from forming.job import Job
from forming.log import Progress, collective_warning
from forming.model import Model
from forming.output import FieldOutput, Recorder, pictures_wanted, write_final_shape
from forming.parallel import peak_rss_mb
from forming.solver import make_solver, penalty_only
from forming.solver.base import StepResult
from forming.solver.stepping import Stepper, StepperState, StepTooSmall
from forming.springs import SpringEscalation

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Checkpoint:
    """The whole state of a simulation between two steps (held in memory).

    :meth:`Simulation.save_checkpoint` writes it to disk (:mod:`forming.restart`).

    Attributes:
        model: The model's snapshot (displacements, history, multipliers).
        solver: The solver's snapshot (predictor, velocities, energies).
        stepper: Load parameter, step size and counters.
        rows: Number of history rows written.
        fields_at: Load parameter of the last field output.
        springs: The stabilising springs' scale and record (:mod:`forming.springs`).
    """

    model: dict
    solver: object
    stepper: StepperState
    rows: int
    fields_at: float | None
    springs: dict | None = None


class Simulation:
    """A job run step by step, writing the output contract into ``out``.

    Args:
        job: What to run.
        out: Output folder (created).
        case: Name of the case (recorded in ``summary.json``).
        parameters: The case's parameters (recorded in ``summary.json``).
        assignments: The ``--set`` items the job was built from (recorded in
            ``summary.json`` and in checkpoints, so that ``--restart`` can rebuild it).
        restart: Continue the run in ``out`` from its checkpoint (``checkpoint.npz``): the
            job must be the one that wrote it. History rows past the checkpoint are
            dropped; the earlier field series are kept as ``<stem>.partN.bp``.

    Raises:
        InputError: The scene is invalid, or (restart) the checkpoint is missing,
            unreadable or written by another model; the folder is then left untouched.
    """

    def __init__(self, job: Job, out: Path, case: str = "run",
                 parameters: dict | None = None, assignments: list[str] | None = None,
                 restart: bool = False):
        self._t_start = time.perf_counter()
        self.job = job
        self._pictures = pictures_wanted()  # FORMING_PICTURES, read (and checked) first
        self.case = case
        self.parameters = dict(parameters or {})
        self.comm = job.scene.mesh.mesh.comm
        self.model = Model(job.scene, penalty_only(job))
        self.model.set_load(0.0)
        if overlaps := self.model.overlaps():
            raise InputError("tools", "; ".join(overlaps) + " at the start: move the tool or "
                             "the blank")
        self.solver = make_solver(job, self.model)
        self.stepper = Stepper(self.solver.step_control(job.steps))
        nw = job.newton
        self.springs = SpringEscalation(
            [*self.model.interfaces, *self.model.sliding],
            nw.spring_escalation if self.solver.retries_on_failure else 1.0,
            nw.spring_escalation_max, nw.spring_escalation_hold)
        self.jit_s = time.perf_counter() - self._t_start
        self.assignments = None if assignments is None else list(assignments)
        self.restarted_from: dict | None = None
        self.last_checkpoint: dict | None = None
        stored = None
        if restart:  # read before anything in the folder changes
            stored = disk.load(disk.checkpoint_path(out), self._layout(), job.scene.mesh.mesh)
        self.recorder = Recorder(out, self.comm, resume=restart)
        self.run_record = provenance.run_record() if self.comm.rank == 0 else {}
        self.status = "running"
        self.reason = ""
        self.signal: str | None = None
        self.recorder.write_summary(self._header())  # a killed run is recognisable
        self.fields = FieldOutput(self.model, self.recorder)
        self.travel = job.travel_mm()
        self.progress = Progress(case, self.travel)
        self._fields_at: float | None = None
        self._work = 0  # the solver's work over every attempted step
        self._started = False
        self._finished: dict | None = None
        if stored is not None:
            self._resume(*stored)

    def _header(self) -> dict:
        """The summary fields known from the start."""
        return {"case": self.case, "status": self.status, "reason": self.reason,
                "load_parameter_reached": self.stepper.t, "run": self.run_record,
                "solver": self.solver.kind, "ranks": self.comm.size,
                "parameters": self.parameters | {"solver": self.solver.kind}
                | self.solver.parameters(), "assignments": self.assignments,
                "checkpoint_every": self.job.checkpoint_every,
                "checkpoint": self.last_checkpoint, "restarted_from": self.restarted_from}

    # -- state -------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Load parameter of the last converged step."""
        return self.stepper.t

    @property
    def done(self) -> bool:
        """True once the load programme is complete or the run has stopped."""
        return self.status != "running" or self.stepper.done

    @property
    def out(self) -> Path:
        """The output folder."""
        return self.recorder.out

    # -- lifecycle ---------------------------------------------------------------------
    def start(self) -> None:
        """Record the initial state (history row 0 and fields at t = 0); idempotent."""
        if self._started:
            return
        self._started = True
        self.model.set_load(0.0)
        self.record(StepResult(True, 0))
        self.write_fields()

    def step(self) -> StepResult:
        """Attempt the next load step; returns what the solver reported.

        A converged step is committed and recorded; a failed one is rolled back and the
        step cut (``stepper``); a step that would be cut below the minimum stiffens the
        interfaces' stabilising springs and goes on at the last accepted size
        (:mod:`forming.springs`) while they may be stiffened further; otherwise, or when
        the solver does not retry, the run stops (:attr:`status` ``"failed"``).

        Raises:
            RuntimeError: The simulation is already done.
        """
        self.start()
        if self.done:
            raise RuntimeError(f"simulation {self.case!r} is done ({self.status})")
        if (sig := signals.requested_anywhere(self.comm)) is not None:
            return self._interrupt(sig, StepResult(False, 0, reason="interrupted"))
        stepper, solver = self.stepper, self.solver
        t_old, t_new = stepper.t, stepper.propose()
        state = (self.model.snapshot(), solver.snapshot())
        solver.advance(t_old, t_new, stepper.last_dt)
        res = solver.solve()
        self._work += res.work
        if res.converged:
            before = stepper.state()
            self.model.commit()
            stepper.accept(t_new, res.work if res.control_work is None else res.control_work)
            scale = self.record(res)
            if scale is None:  # the case's probe failed: back to the last recorded state
                self.model.restore(state[0])
                solver.restore(state[1])
                stepper.restore(before)
                self.model.set_load(stepper.t)
                return res
            solver.accept(scale)
            self.springs.commit(t_new)
            self.progress.step(stepper.n_accepted, t_new, stepper.last_dt,
                               f"{res.work} {solver.work_name}", res.seconds)
            if stepper.n_accepted % self.job.field_every == 0 or stepper.done:
                self.write_fields()
            every = self.job.checkpoint_every
            if every and stepper.n_accepted % every == 0 and not stepper.done:
                self.save_checkpoint(f"every {every} steps")
            return res
        self.model.restore(state[0])
        solver.restore(state[1])
        if (sig := signals.requested_anywhere(self.comm)) is not None:
            return self._interrupt(sig, res)
        if not solver.retries_on_failure or res.final:
            return self._fail(f"at {self.progress.where(t_old)} (load parameter {t_old:.6g}):"
                              f" {res.reason}", res)
        collective_warning(log, "step to %s (t=%.5f) failed after %d %s: %s; cutting back",
                           self.progress.where(t_new), t_new, res.work, solver.work_name,
                           res.reason)
        try:
            stepper.reject()
        except StepTooSmall as exc:
            if (spring := self.springs.stiffen(stepper.t)) is None:
                held = (f"; springs at {self.springs.scale:g} times their setting"
                        if self.springs.scale > 1.0 else "")
                return self._fail(f"{exc} ({self.progress.where(stepper.t)}); last failure: "
                                  f"{res.reason}{held}", res)
            stepper.resume(stepper.last_dt or stepper.control.initial)
            collective_warning(log, "%s: stabilising springs stiffened to %g times their "
                               "setting; retrying", exc, spring)
        return res

    def _interrupt(self, signum: int, res: StepResult) -> StepResult:
        """Stop the run at the last converged state on a stop request (SIGINT, SIGTERM)."""
        self.signal = signals.signal_name(signum)
        self.status = "interrupted"
        self.reason = (f"interrupted by {self.signal} at {self.progress.where(self.t)} "
                       f"(load parameter {self.t:.6g})")
        self.model.set_load(self.stepper.t)
        collective_warning(log, "run stopped: %s", self.reason)
        self.save_checkpoint(f"interrupted by {self.signal}")  # --restart goes on from here
        return res

    def _fail(self, reason: str, res: StepResult) -> StepResult:
        """Stop the run at the last converged state (already restored), and checkpoint it.

        The checkpoint holds that state, not the last periodic one: a run resumed from it
        (after a change to the code, or to study the state in Python) starts where the
        failure left it.
        """
        self.status, self.reason = "failed", reason
        self.model.set_load(self.stepper.t)  # tools and prescribed values back to it
        log.error("run stopped: %s", reason)
        self.save_checkpoint("the last converged step of a failed run")
        return res

    def run(self) -> dict:
        """Step to the end of the load programme (or a failure) and finish."""
        self.start()
        while not self.done:
            self.step()
        return self.finish()

    # -- output hooks -----------------------------------------------------------------
    def record(self, result: StepResult) -> float | None:
        """Append the history row of the current (converged) state.

        Each writer adds its own columns (the stepper's, the solver's, the model's
        objects', the case's probe); a column written twice is an error.

        Returns:
            The step's force scale: the largest reaction or tool force [N]; None when the
            case's probe raised (the run has failed and the row is not written).
        """
        row: dict[str, float] = {}
        owners: dict[str, str] = {}
        st, copies = self.stepper, self.job.scene.symmetry_copies
        merge(row, {"step": st.n_accepted, "t": st.t, "dt": st.last_dt}, "stepper", owners)
        if self.travel is not None:
            merge(row, {STROKE: st.t * self.travel}, "stepper", owners)
        merge(row, whole_part(self.solver.history_columns(result), copies),
              f"{self.solver.kind} solver", owners)
        merge(row, {"step_wall_s": result.seconds}, "simulation", owners)
        merge(row, self.springs.history_columns(), "springs", owners)
        model_columns = self.model.history_columns(self.solver)
        scale = self._force_scale(model_columns)  # of the modelled part (Newton's tolerance)
        merge(row, whole_part(model_columns, copies), "model", owners)
        if self.job.probe is not None:
            probed = self._hook("probe", self.job.probe, self.model)
            if probed is None:
                return None
            merge(row, probed, "case probe", owners)
        self.recorder.record(row)
        return scale

    def _force_scale(self, row: dict[str, float]) -> float:
        scale = max((abs(row[reaction_column(k)]) for k in self.model.dirichlet.reaction_keys),
                    default=0.0)
        for c in self.model.contacts:
            scale = max(scale, float(np.linalg.norm([row[force_column(c.name, i)]
                                                     for i in range(3)])))
        return scale

    def write_fields(self) -> None:
        """Write the ParaView fields of the current state."""
        self.fields.write(self.stepper.n_accepted, self.stepper.t)
        self._fields_at = self.stepper.t

    def checkpoint(self) -> Checkpoint:
        """The simulation's state between two steps (in memory)."""
        self.start()
        return Checkpoint(self.model.snapshot(), self.solver.snapshot(), self.stepper.state(),
                          len(self.recorder.rows), self._fields_at, self.springs.state())

    def restore(self, cp: Checkpoint) -> None:
        """Return to a checkpoint: model, solver, stepper and history rows.

        Fields already written past the checkpoint stay in the ``.bp`` series; the next
        output appends to it.
        """
        self.model.restore(cp.model)
        self.solver.restore(cp.solver)
        self.stepper.restore(cp.stepper)
        self.springs.restore(cp.springs)
        self.model.set_load(self.stepper.t)
        self.recorder.truncate(cp.rows)
        self._fields_at = cp.fields_at
        self.status, self.reason = "running", ""

    # -- checkpoints on disk ---------------------------------------------------------------
    def _layout(self) -> dict:
        """Where the arrays of a checkpoint's snapshots live (forming.restart)."""
        return {"model": self.model.snapshot_layout(), "solver": self.solver.snapshot_layout()}

    def save_checkpoint(self, reason: str = "asked") -> dict | None:
        """Write the current state to ``checkpoint.npz`` for ``--restart`` (collective).

        The file holds :meth:`checkpoint` (model, solver, stepper, history rows), readable
        on any number of ranks (:mod:`forming.restart`). A write that fails is logged and
        the run goes on with its previous checkpoint.

        Args:
            reason: Why it is written (recorded in the file and in ``summary.json``).

        Returns:
            What ``summary.json`` records of it, or None if it could not be written.
        """
        cp = self.checkpoint()
        st = cp.stepper
        meta = {"case": self.case, "assignments": self.assignments, "step": st.n_accepted,
                "t": st.t, "ranks": self.comm.size, "reason": reason,
                "written": provenance.now() if self.comm.rank == 0 else "",
                "stepper": dataclasses.asdict(st), "fields_at": cp.fields_at,
                "work": self._work, "checkpoint_every": self.job.checkpoint_every,
                "springs": cp.springs,
                "rows": self.recorder.rows[: cp.rows]}
        path = disk.checkpoint_path(self.out)
        t0 = time.perf_counter()
        try:
            disk.save(path, {"model": cp.model, "solver": cp.solver}, self._layout(), meta,
                      self.job.scene.mesh.mesh)
        except OSError as exc:
            log.warning("checkpoint not written (%s); the previous one stays", exc)
            return None
        self.last_checkpoint = self._checkpoint_record(st.n_accepted, st.t, reason)
        log.info("checkpoint at step %d (%s) written in %.2f s", st.n_accepted,
                 self.progress.where(st.t), time.perf_counter() - t0)
        if self._finished is None:  # a run killed from here on says where to resume
            self.recorder.write_summary(self._header())
        return self.last_checkpoint

    def _checkpoint_record(self, step: int, t: float, reason: str) -> dict:
        """What ``summary.json`` says of the checkpoint: file, step, why, how to resume."""
        how = (f"forming run {self.case} --restart {self.out}" if self.assignments is not None
               else "Simulation(job, out, restart=True) with the job that wrote it")
        return {"file": disk.FILE_NAME, "step": step, "t": t, "reason": reason,
                "restart": how}

    def _resume(self, state: dict, meta: dict) -> None:
        """Continue from a checkpoint read from disk (a restart)."""
        cp = Checkpoint(state["model"], state["solver"], StepperState(**meta["stepper"]),
                        len(meta["rows"]), meta["fields_at"], meta.get("springs"))
        fresh = self.springs.history_columns()  # scale 1 in rows from before the column
        self.recorder.rows = [r | {k: v for k, v in fresh.items() if k not in r}
                              for r in meta["rows"]]
        self.restore(cp)
        self._started = True
        self._work = meta["work"]
        self.restarted_from = {"file": disk.FILE_NAME, "step": cp.stepper.n_accepted,
                               "t": cp.stepper.t, "ranks": meta["ranks"],
                               "reason": meta["reason"], "written": meta["written"],
                               "earlier_fields": self.recorder.earlier_fields}
        self.last_checkpoint = self._checkpoint_record(cp.stepper.n_accepted, cp.stepper.t,
                                                       meta["reason"])
        self.write_fields()  # the new field series starts at the checkpoint
        self.recorder.write_summary(self._header())
        log.info("restarted from the checkpoint at step %d (%s), written on %d rank(s)",
                 cp.stepper.n_accepted, self.progress.where(cp.stepper.t), meta["ranks"])

    def _hook(self, name: str, fn, *args):
        """Call a case hook; an exception fails the run but keeps what was computed."""
        if fn is None:
            return None
        try:
            return fn(*args)
        except Exception as exc:  # noqa: BLE001  (a case's code: report, never lose the run)
            log.exception("case %s raised", name)
            why = f"case {name} raised {type(exc).__name__}: {exc}"
            self.reason = f"{self.reason}; {why}" if self.reason else why
            self.status = "failed"
            return None

    def finish(self) -> dict:
        """Close the output, evaluate the case's metrics and write ``summary.json``.

        Returns:
            The summary (as written); calling again returns it unchanged.
        """
        if self._finished is not None:
            return self._finished
        self.start()
        if self.status == "running":
            self.status = "completed" if self.stepper.done else "stopped"
            if not self.stepper.done:
                self.reason = (f"stopped by its driver at {self.progress.where(self.t)} "
                               f"(load parameter {self.t:.6g})")
        self.progress.close()
        if self._fields_at != self.stepper.t:
            self.write_fields()
        self.recorder.close()
        job, model, comm, rec = self.job, self.model, self.comm, self.recorder
        metrics, notes = _numbers(self._hook("metrics", job.metrics, rec, model) or {})
        metrics |= self.solver.metrics()
        warnings = (list(job.cautions) + model.warnings() + self.solver.warnings()
                    + self.springs.warnings(self.progress.where))
        for w in warnings:
            collective_warning(log, "%s", w)
        validity = self.solver.validity() | {
            f"{name} <= {bound:g}": metrics.get(name) is not None and metrics[name] <= bound
            for name, bound in job.limits}
        bodies = list(model.bodies.values())
        summary = self._header() | {
            "metrics": metrics,
            "metric_notes": notes,
            "valid": all(validity.values()),
            "validity": validity,
            "warnings": warnings,
            "timing": {
                "wall_s": time.perf_counter() - self._t_start, "jit_s": self.jit_s,
                "steps": self.stepper.n_accepted, "rejected_steps": self.stepper.n_rejected,
                "kernel_s": comm.allreduce(sum(b.kernel_seconds for b in bodies)) / comm.size,
                "work_name": self.solver.work_name, "work": self._work,
                "peak_rss_mb": peak_rss_mb(comm),
            } | self.springs.summary() | self.solver.timing(),
            "mesh": {"cells": sum(comm.allreduce(b.n_local_cells) for b in bodies),
                     "dofs": sum(b.V.dofmap.index_map.size_global * 3 for b in bodies),
                     "quadrature_points_per_cell": bodies[0].n_points
                     // max(bodies[0].n_local_cells, 1),
                     "symmetry_copies": job.scene.symmetry_copies},
            "versions": compat.versions(),
            "outputs": ["summary.json", "history.csv", *self.fields.outputs(),
                        "final_shape.npz", *self.recorder.earlier_fields]
            + ([disk.FILE_NAME] if self.last_checkpoint else []),
        }
        if self.signal is not None:
            summary["signal"] = self.signal
        write_final_shape(rec.out / "final_shape.npz", model.bodies, comm)
        pictures, t0 = job.pictures if self._pictures else None, time.perf_counter()
        summary["outputs"] += [p.name for p in self._hook("pictures", pictures, model,
                                                            rec.out) or []]
        summary["timing"]["pictures_s"] = time.perf_counter() - t0  # (rank 0 draws them)
        if comm.rank == 0 and rec.rows:
            summary["outputs"] += [p.name for p in self._hook("plots", job.plots, rec,
                                                                rec.out) or []]
        summary |= {"status": self.status, "reason": self.reason}  # a hook may have failed
        summary["run"] = self.run_record | {"finished": provenance.now()}
        rec.write_summary(summary)
        self._finished = summary
        return summary


def _numbers(metrics: dict) -> tuple[dict, dict[str, str]]:
    """Metrics with every non-finite number replaced by None, and a note saying why."""
    out, notes = {}, {}
    for key, value in metrics.items():
        if isinstance(value, float | np.floating) and not np.isfinite(value):
            out[key] = None
            notes[key] = f"not defined for this run (computed {value})"
        else:
            out[key] = value
    return out, notes
