"""The step API: a simulation driven from outside, checkpoints, failures, history writers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import block_scene, history

from forming.case import prepare_case
from forming.history import DuplicateColumn
from forming.job import Job, Response
from forming.materials.library import honeycomb_core
from forming.run import simulate
from forming.simulation import Simulation
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

WALL = ("step_wall_s",)
CRUSHING = ["cells=4,4,2", "stroke=1.5"]  # contact, friction, plasticity: every kind of state


def _same_rows(a: list[dict], b: list[dict]) -> None:
    """Bit-for-bit equal history rows (wall-time columns aside)."""
    assert len(a) == len(b)
    for ra, rb in zip(a, b, strict=True):
        assert ra.keys() == rb.keys()
        for k in ra:
            if k not in WALL:
                assert ra[k] == rb[k], (k, ra[k], rb[k])


def _crushing(solver: str = "implicit") -> Job:
    sets = CRUSHING + ([] if solver == "implicit" else
                       ["solver=explicit", "explicit.loading_time=0.005"])
    return prepare_case("core_crushing", sets)[0]


def test_driver_steps_reproduce_simulate(tmp_path):
    """A driver that steps a Simulation from outside, stops half-way to read the model,
    and goes on gets exactly the history of ``simulate()``.

    A difference means the step API and the loop around it do not share one lifecycle
    (e.g. reading the model between steps changed its state).
    """
    job = _crushing()
    ref = simulate(job, tmp_path / "loop", "core_crushing", {})
    sim = Simulation(job, tmp_path / "driven", "core_crushing")
    forces = []
    while not sim.done:
        sim.step()
        if sim.t >= 0.5 and not forces:
            forces.append(sim.model.contacts[0].force()[2])  # a driver reads the model
    summary = sim.finish()
    assert summary["status"] == ref["status"] == "completed"
    assert forces and forces[0] > 0.0
    _same_rows(sim.recorder.rows, [dict(zip(h.dtype.names, map(float, h), strict=True))
                                   for h in history(tmp_path / "loop")])
    assert summary["metrics"] == ref["metrics"]


def test_driver_may_stop_early(tmp_path):
    """finish() before the end of the load programme says so: status "stopped"."""
    sim = Simulation(_crushing(), tmp_path, "core_crushing")
    while sim.t < 0.3:
        sim.step()
    summary = sim.finish()
    assert summary["status"] == "stopped"
    assert summary["load_parameter_reached"] == pytest.approx(sim.t)
    assert "driver" in summary["reason"]
    with pytest.raises(RuntimeError, match="done"):
        sim.step()


@pytest.mark.parametrize("solver", ["implicit", "explicit"])
def test_checkpoint_restore_is_exact(tmp_path, solver):
    """Checkpoint at t = 0.4, step on, corrupt every part of the state (displacement,
    plastic history, contact multipliers, velocities), restore, and finish: the history
    equals an uninterrupted run's bit for bit.

    A difference means a piece of state is missing from the checkpoint.
    """
    job = _crushing(solver)
    ref = Simulation(job, tmp_path / "ref", "ref")
    ref.run()
    sim = Simulation(job, tmp_path / "cp", "cp")
    while sim.t < 0.4:
        sim.step()
    cp = sim.checkpoint()
    for _ in range(2):
        sim.step()
    body = sim.model.body
    body.u.x.array[:] += 0.1
    body.plastic.evp[:] += 0.5
    for c in sim.model.contacts:
        c.lam_n.x.array[:] += 1.0
    sim.restore(cp)
    sim.run()
    _same_rows(sim.recorder.rows, ref.recorder.rows)


def test_failed_run_keeps_the_last_converged_state(tmp_path):
    """A run whose steps cannot converge stops with "failed": its last history row is its
    last accepted step, ``final_shape.npz`` holds that step's displacement, and the
    reaction recomputed from the kept state equals the one recorded for it.

    The checkpoint on disk is that state too (not the last periodic one): restored into
    a fresh simulation of the same job, it gives the kept displacement exactly.

    A failure means the output mixes the failed iterate with the converged state.
    """
    foam = honeycomb_core("isotropic", nu=0.3)
    job = Job(scene=block_scene(foam, clamped=True, stroke=-8.0),
              newton=NewtonOptions(max_it=3, predictor="previous"),
              steps=StepControl(initial=0.02, max=0.3, min=0.015, grow=3.0))
    sim = Simulation(job, tmp_path, "doomed")
    summary = sim.run()
    assert summary["status"] == "failed" and "minimum" in summary["reason"]
    last = sim.recorder.rows[-1]
    assert summary["timing"]["steps"] == 2 and summary["timing"]["rejected_steps"] >= 2
    assert last["step"] == summary["timing"]["steps"]
    assert last["t"] == summary["load_parameter_reached"] == sim.t
    body = sim.model.body
    x, u = body.nodal_coordinates(), body.nodal_displacements()
    with np.load(tmp_path / "final_shape.npz") as z:
        order = np.lexsort(np.round(x, 9).T[::-1])
        np.testing.assert_array_equal(z["core_X"], x[order])
        np.testing.assert_array_equal(z["core_u"], u[order])
    # the prescribed face sits where the last accepted step put it
    top = np.isclose(x[:, 2], 10.0)
    np.testing.assert_allclose(u[top, 2], -8.0 * sim.t, rtol=0, atol=1e-12)
    assert sim.model.dirichlet.reaction("top_z") == pytest.approx(last["reaction_top_z_N"],
                                                                  rel=1e-12)
    assert summary["checkpoint"]["step"] == summary["timing"]["steps"]
    assert summary["checkpoint"]["t"] == sim.t and "failed" in summary["checkpoint"]["reason"]
    resumed = Simulation(job, tmp_path, "doomed", restart=True)
    assert resumed.t == sim.t
    np.testing.assert_array_equal(resumed.model.body.nodal_displacements(), u)


def test_a_column_written_twice_is_an_error(tmp_path):
    """A probe that writes a column the stepper owns is refused, naming both writers."""
    job = Job(scene=block_scene(honeycomb_core("isotropic")),
              probe=lambda model: {"t": 0.0})
    with pytest.raises(DuplicateColumn, match="stepper.*case probe"):
        Simulation(job, tmp_path, "dup").start()


def test_history_and_summary_agree_for_a_quarter_model(tmp_path):
    """core_crushing is a quarter model (4 symmetry copies): the history's punch force and
    crushed volume are whole-part figures, equal to the summary's metrics and to 4 times
    the force of the model's own contact; the stroke column is in mm.

    A failure means a figure is reported for the quarter in one file and for the whole
    part in another.
    """
    job = _crushing()
    assert job.scene.symmetry_copies == 4
    sim = Simulation(job, tmp_path, "core_crushing")
    m = sim.run()["metrics"]
    h = history(tmp_path)
    assert m["punch_force_max_N"] == h["force_punch_z_N"].max()
    assert m["punch_force_final_N"] == h["force_punch_z_N"][-1]
    assert m["crushed_volume_mm3"] == pytest.approx(h["crushed_volume_mm3"][-1], rel=1e-12)
    own = sim.model.contacts[0].force()[2]
    assert h["force_punch_z_N"][-1] == pytest.approx(4 * own, rel=1e-12)
    assert h["stroke_mm"][-1] == pytest.approx(1.5, rel=1e-12)
    assert job.response_or_default().scale == 1.0
    fixed = dataclasses.replace(job, response=Response("force_punch_z_N", 3.0, -1.0))
    assert fixed.response_or_default().scale == -1.0


def test_default_response_is_the_recorded_reaction_against_the_travel():
    """A scene without tools compares its first recorded reaction, against the travel of
    its prescribed face (the block's top moves 2 mm: travel 2 mm)."""
    job = Job(scene=block_scene(honeycomb_core("isotropic")))
    r = job.response_or_default()
    assert (r.column, r.travel, r.scale) == ("reaction_top_z_N", 2.0, 1.0)


def test_simulate_destroys_the_petsc_solver_itself(tmp_path, monkeypatch):
    """``simulate`` destroys the Newton solver at its end, not the garbage collector.

    PETSc's destruction of a parallel solver is collective (MUMPS ends its instance on
    every rank). Left to the collector, a rank that holds the simulation in a reference
    cycle frees it later than the others, which then wait for ever: a 2-rank
    demonstrator run hung after writing its summary (2026-11-28). A failure means the
    solver outlives ``simulate`` and its destruction is again left to chance.
    """
    made = []
    real_init = Simulation.__init__

    def keep(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(Simulation, "__init__", keep)
    summary = simulate(_crushing(), tmp_path, "core_crushing", {})
    assert summary["status"] == "completed"
    problem = made[0].solver.problem
    assert problem.solver.handle == 0 and problem.A.handle == 0 and problem.b.handle == 0
