"""Restart from a checkpoint on disk: the same final state as an uninterrupted run.

The case is core_crushing on 4 x 4 x 2 cells over a 1.5 mm stroke: crushable-foam
plasticity (volumetric plastic strain as history), Coulomb friction at the punch and the
plate (tangential multipliers and slip references), and cut-back steps before the
checkpoint (the stepper's state). The interrupted run writes a checkpoint every 4 steps
and is stopped by its driver after step 9, so the restart goes on from step 8, where
plasticity has set in and three steps have been cut back.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest
from helpers import history, run_mpi

from forming.case import prepare_case, run_case
from forming.cli import main as cli_main
from forming.errors import InputError
from forming.run import simulate
from forming.simulation import Simulation

CASE = "core_crushing"
CRUSHING = ["cells=4,4,2", "stroke=1.5"]
EVERY, STOP_AFTER, RESUMED_AT = 4, 9, 8
FORCE = "force_punch_z_N"
WALL = ("step_wall_s",)


def _job(**changes):
    """The case's job without pictures and plots (they cost time and hold no state)."""
    job, params = prepare_case(CASE, CRUSHING)
    return dataclasses.replace(job, pictures=None, plots=None, **changes), params


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """An uninterrupted run, and one stopped by its driver after step 9 (checkpoint at 8)."""
    root = tmp_path_factory.mktemp("restart")
    job, params = _job(checkpoint_every=EVERY)
    Simulation(job, root / "uninterrupted", CASE, params, CRUSHING).run()
    sim = Simulation(job, root / "stopped", CASE, params, CRUSHING)
    while sim.stepper.n_accepted < STOP_AFTER:
        sim.step()
    assert sim.finish()["status"] == "stopped"
    return {"uninterrupted": root / "uninterrupted", "stopped": root / "stopped"}


def _copy(runs: dict[str, Path], tmp_path: Path) -> Path:
    """A fresh copy of the stopped run (a restart writes into its folder)."""
    return Path(shutil.copytree(runs["stopped"], tmp_path / "stopped"))


def _max_rel_diff(a: np.ndarray, b: np.ndarray, column: str) -> float:
    """Largest difference of a history column, relative to its largest magnitude."""
    return float(np.abs(a[column] - b[column]).max() / np.abs(a[column]).max())


def test_restart_on_the_same_ranks_equals_the_uninterrupted_run(runs, tmp_path):
    """Restart the stopped run from its checkpoint (``run_case(..., restart=True)``, what
    ``forming run core_crushing --restart DIR`` calls): every history row equals the
    uninterrupted run's, forces within 1e-8 relative (measured: bit for bit, 0.0), rows
    9 of the stopped run are dropped, and the summary says where it restarted from.

    A failure means a piece of state does not round-trip through the file (a history
    variable, a multiplier, the predictor, the stepper) or the restart rebuilt another
    job than the one that wrote the checkpoint.
    """
    folder = _copy(runs, tmp_path)
    summary = run_case(CASE, folder, [], restart=True)
    assert summary["status"] == "completed"
    assert summary["restarted_from"]["step"] == RESUMED_AT
    assert summary["restarted_from"]["ranks"] == 1
    assert summary["assignments"] == CRUSHING
    ref, got = history(runs["uninterrupted"]), history(folder)
    assert len(got) == len(ref) and np.array_equal(got["t"], ref["t"])
    for column in ref.dtype.names:
        if column.startswith("force_"):
            assert _max_rel_diff(ref, got, column) <= 1e-8, column
        elif column not in WALL:
            np.testing.assert_allclose(got[column], ref[column], rtol=1e-8, atol=1e-12,
                                       err_msg=column)
    with np.load(runs["uninterrupted"] / "final_shape.npz") as a, \
            np.load(folder / "final_shape.npz") as b:
        np.testing.assert_allclose(b["core_u"], a["core_u"], rtol=0, atol=1e-10)
    # the fields of the run before the restart are kept beside the new series
    assert (folder / "displacement.part1.bp").is_dir() and (folder / "displacement.bp").is_dir()
    assert "displacement.part1.bp" in summary["outputs"]


@pytest.mark.mpi
@pytest.mark.parametrize("case, sets", [
    (CASE, CRUSHING),
    ("skin_sled", ["drag=1.0"]),  # skins on a core: submeshes and frictional interfaces
])
def test_restart_on_two_ranks_matches_the_serial_run(tmp_path, case, sets):
    """A checkpoint written on 1 rank, resumed on 2 (``mpirun -n 2 python cases/X.py
    --restart DIR``): the same steps as the uninterrupted serial run and the same forces
    within 1e-8 of the peak.

    Two ranks sum the cell contributions in another order, so every Newton iterate
    differs by round-off; where both runs take the same steps their forces agree to the
    round-off of the solve. Measured, each column against its own peak: core_crushing
    2.7e-13 (punch z force) and at most 1.3e-12 (the lateral forces), about what an
    uninterrupted 2-rank run differs from the serial one (3e-13); skin_sled 2.2e-14
    (reaction) and 9e-16 (interface forces). Over a full stroke the step paths may part,
    and then differences up to Newton's force tolerance (1e-4) are legitimate
    (tests/test_parallel.py); here the steps are checked equal and 1e-8 leaves four
    orders of magnitude above the round-off. A failure means per-cell data landed on the
    wrong cells of the new partition (the keying by original cell index) or ghost values
    were not restored.
    """
    job, params = prepare_case(case, sets)
    job = dataclasses.replace(job, pictures=None, plots=None, checkpoint_every=EVERY)
    simulate(job, tmp_path / "serial", case, params, sets)
    sim = Simulation(job, tmp_path / "restarted", case, params, sets)
    while sim.stepper.n_accepted < EVERY + 1:
        sim.step()
    sim.finish()
    proc = run_mpi([f"cases/{case}.py", "--restart", str(tmp_path / "restarted")],
                   timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads((tmp_path / "restarted" / "summary.json").read_text())
    assert summary["ranks"] == 2 and summary["restarted_from"]["ranks"] == 1
    assert summary["restarted_from"]["step"] == EVERY
    ref, got = history(tmp_path / "serial"), history(tmp_path / "restarted")
    assert np.array_equal(got["t"], ref["t"])
    forces = [c for c in ref.dtype.names if c.endswith("_N") and np.abs(ref[c]).max() > 1e-9]
    assert forces
    for column in forces:
        assert _max_rel_diff(ref, got, column) <= 1e-8, column


def test_history_variables_and_multipliers_matter(runs, tmp_path):
    """Why the exact restart is a real check: resumed without the plastic history, or
    without the friction multipliers and slip references, the run goes elsewhere.

    Measured from the step-8 checkpoint: the punch force curve then differs from the
    uninterrupted one by up to 13% of the peak (plastic strain zeroed), 1.5% (tangential
    multipliers zeroed) and 2.4% (slip references zeroed), with other step paths; the
    exact restart differs by 0. A failure (no difference) means this case no longer
    exercises that state, and the restart tests above would miss its loss.
    """
    job, params = _job()
    ref = history(runs["uninterrupted"])

    def resumed(spoil) -> float:
        folder = Path(shutil.copytree(runs["stopped"], tmp_path / spoil.__name__))
        sim = Simulation(job, folder, CASE, params, CRUSHING, restart=True)
        spoil(sim.model)
        sim.run()
        t, f = sim.recorder.column("t"), sim.recorder.column(FORCE)
        return float(np.abs(np.interp(t, ref["t"], ref[FORCE]) - f).max()
                     / np.abs(ref[FORCE]).max())

    def no_plastic_strain(model):
        body = model.body
        body.plastic.restore((0 * body.plastic.ep, 0 * body.plastic.evp))

    def no_friction_multipliers(model):
        for c in model.contacts:
            c.lam_t.x.array[:] = 0.0

    assert resumed(no_plastic_strain) > 0.05
    assert resumed(no_friction_multipliers) > 0.005


def test_an_interrupted_run_leaves_a_checkpoint_to_restart_from(runs, tmp_path):
    """Ctrl-C (SIGINT, here raised by the case's probe after step 5) with checkpoints
    off: the run ends ``interrupted`` and leaves a checkpoint of its last converged step,
    named in ``summary.json``; ``--restart`` from it reaches the uninterrupted run's
    forces (1e-8).

    A failure means a stop request loses the state a restart needs.
    """
    job, params = _job(checkpoint_every=0)
    probe = job.probe

    def interrupting(model):
        if len(seen) == 5:
            signal.raise_signal(signal.SIGINT)
        seen.append(model.t)
        return probe(model)

    seen: list[float] = []
    folder = tmp_path / "interrupted"
    summary = simulate(dataclasses.replace(job, probe=interrupting), folder, CASE, params,
                       CRUSHING)
    assert summary["status"] == "interrupted" and summary["signal"] == "SIGINT"
    assert summary["checkpoint"]["step"] == 5 and summary["checkpoint"]["file"] == \
        "checkpoint.npz"
    assert "--restart" in summary["checkpoint"]["restart"]
    summary = run_case(CASE, folder, [], restart=True)
    assert summary["status"] == "completed" and summary["restarted_from"]["step"] == 5
    ref, got = history(runs["uninterrupted"]), history(folder)
    assert np.array_equal(got["t"], ref["t"])
    assert _max_rel_diff(ref, got, FORCE) <= 1e-8


def test_bad_restarts_are_refused_naming_the_path(runs, tmp_path):
    """A missing folder, a folder without a checkpoint, a corrupt checkpoint, another
    case, a changed parameter, another mesh: each is an InputError that names the path
    or the setting, and the folder is left as it was. A file left by a write that was
    killed (``checkpoint.npz.tmp``) does not matter: the previous checkpoint is whole.
    """
    folder = _copy(runs, tmp_path)
    before = (folder / "summary.json").read_text()
    with pytest.raises(InputError, match="does not exist"):
        run_case(CASE, tmp_path / "nowhere", [], restart=True)
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"holds no checkpoint"):
        run_case(CASE, tmp_path / "empty", [], restart=True)
    with pytest.raises(InputError, match="holds a run of case 'core_crushing'"):
        run_case("core_compression", folder, [], restart=True)
    with pytest.raises(InputError, match=r"cannot change \['stroke'\]"):
        run_case(CASE, folder, ["stroke=2.0"], restart=True)
    job, params = _job()
    for sets, message in ((["cells=4,4,3"], "mesh has 32 cells, this one 48"),
                          (["size=100"], "mesh differs")):
        other, _ = prepare_case(CASE, [*CRUSHING, *sets])
        with pytest.raises(InputError, match=message):
            Simulation(other, folder, CASE, params, CRUSHING, restart=True)
    assert (folder / "summary.json").read_text() == before
    (folder / "checkpoint.npz.tmp").write_bytes(b"half a checkpoint")
    Simulation(job, folder, CASE, params, CRUSHING, restart=True)  # reads the whole one
    corrupt = _copy(runs, tmp_path / "corrupt")
    (corrupt / "checkpoint.npz").write_bytes(b"not a zip file")
    with pytest.raises(InputError, match=f"{corrupt / 'checkpoint.npz'} is not a readable"):
        run_case(CASE, corrupt, [], restart=True)
    with pytest.raises(SystemExit) as exit_:  # the command line: exit code 2 (bad input)
        cli_main(["run", CASE, "--restart", str(corrupt), "--quiet"])
    assert exit_.value.code == 2


def test_explicit_restart_is_exact(tmp_path):
    """The explicit solver's state (velocities, accelerations, force vectors, time,
    energies, stable time step) round-trips too: resumed from the checkpoint after output
    interval 20 of 50, the history equals the uninterrupted run's (measured: bit for bit;
    asserted 1e-8). The resumed run's cost per element and increment is of the increments
    it ran itself, not of those before the checkpoint too. A failure means a part of the
    solver's snapshot is lost on disk, or the resumed run reports a cost it did not have.
    """
    sets = [*CRUSHING, "solver=explicit", "explicit.loading_time=0.005"]
    sim = _resumed_equals_uninterrupted(tmp_path, CASE, sets, (
        "t", "time_s", FORCE, "energy_internal_Nmm", "energy_friction_Nmm",
        "energy_kinetic_Nmm", "work_external_Nmm"))
    solver = sim.solver
    assert 0 < solver.steps_run < solver.time_steps
    timing = solver.timing()
    assert timing["us_per_element_increment"] == pytest.approx(
        1e6 * timing["integration_s"] / (solver.steps_run * timing["elements"]), rel=1e-12)


def test_explicit_adaptive_restart_is_exact(tmp_path):
    """Adaptive integration's state round-trips: which elements are fully integrated,
    their hourglass springs, the retired hourglass work and the count to the next check
    (without it the resumed run checked on other increments and its punch force departed
    by 2.5e-5 of its peak). On this 4 x 4 x 2 mesh every element has moved by the end.
    Resumed from the checkpoint after output interval 20 of 50,
    the history equals the uninterrupted run's (asserted 1e-8). A failure means a
    resumed adaptive run integrates other elements fully, or loses hourglass state.
    """
    sets = [*CRUSHING, "solver=explicit", "explicit.loading_time=0.005",
            "explicit.integration=adaptive"]
    sim = _resumed_equals_uninterrupted(tmp_path, CASE, sets, (
        "t", FORCE, "energy_internal_Nmm", "energy_kinetic_Nmm", "energy_hourglass_Nmm"))
    assert sim.solver.metrics()["full_integration_fraction"] > 0.0


def _resumed_equals_uninterrupted(tmp_path, case: str, sets: list[str],
                                  columns) -> Simulation:
    """Stop a run after output interval 25 of 50, resume it from its checkpoint at 20,
    and compare the history ``columns`` with an uninterrupted run's (1e-8 relative).

    Returns:
        The resumed run, finished.
    """
    job, params = prepare_case(case, sets)
    job = dataclasses.replace(job, pictures=None, plots=None, checkpoint_every=20)
    ref = Simulation(job, tmp_path / "uninterrupted", case, params, sets)
    ref.run()
    sim = Simulation(job, tmp_path / "stopped", case, params, sets)
    while sim.stepper.n_accepted < 25:
        sim.step()
    sim.finish()
    sim = Simulation(job, tmp_path / "stopped", case, params, sets, restart=True)
    assert sim.stepper.n_accepted == 20
    sim.run()
    assert len(sim.recorder.rows) == len(ref.recorder.rows)
    for column in columns:
        a, b = ref.recorder.column(column), sim.recorder.column(column)
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), column
    return sim


def test_explicit_restart_keeps_the_filtered_friction_pressure(tmp_path):
    """The explicit skin sled with its friction reading a filtered pressure
    (``explicit.friction_filter``, 0.25 ms over a 2.5 ms load): the filter's values are
    solver state, so a run resumed from output interval 20 of 50 repeats the
    uninterrupted history (asserted 1e-8). A failure means the filtered pressure is
    not in the checkpoint (the resumed friction restarts from zero pressure)."""
    sets = ["solver=explicit", "explicit.loading_time=0.0025", "explicit.friction_filter=2.5e-4"]
    _resumed_equals_uninterrupted(tmp_path, "skin_sled", sets, (
        "reaction_skin_top_top_x_N", "energy_friction_Nmm", "energy_kinetic_Nmm"))


def test_restart_of_a_stabilised_fracturing_run_is_exact(tmp_path):
    """A block of fracturing cardboard pulled past its fracture strain with the viscous
    stabilisation on (the meso walls' setting), stopped after 9 steps and restarted from
    its checkpoint at 8: every history row, including the fracture and stabilisation
    energies, equals the uninterrupted run's within 1e-10.

    A failure means the damage history (damage, band, dissipated energy) or the
    stabilisation's coefficient and energies do not round-trip through the checkpoint.
    """
    from forming.job import Job
    from forming.materials.elasticity import IsotropicElasticity
    from forming.materials.fracture import FracturingSolid
    from forming.mesh import box
    from forming.post.fields import fracture_energy
    from forming.scene import Body, Displacement, Linear, Scene, Stabilisation
    from forming.solver.stepping import StepControl

    block = FracturingSolid(IsotropicElasticity(410.0, 0.21), erosion=True)
    scene = Scene("pull", box((10.0, 10.0, 10.0), (2, 2, 2)), (Body("core", block),),
                  displacements=(Displacement("core", "bottom", z=0.0, reaction=False),
                                 Displacement("core", "xmin", x=0.0, reaction=False),
                                 Displacement("core", "ymin", y=0.0, reaction=False),
                                 Displacement("core", "top", z=Linear(1.5))),
                  stabilisation=Stabilisation(2e-4))
    job = Job(scene, steps=StepControl(initial=0.05, max=0.05, min=1e-4),
              probe=lambda model: {"fracture_energy_Nmm": fracture_energy(model.body)},
              checkpoint_every=EVERY)
    Simulation(job, tmp_path / "uninterrupted", "pull").run()
    sim = Simulation(job, tmp_path / "stopped", "pull")
    while sim.stepper.n_accepted < STOP_AFTER:
        sim.step()
    assert sim.finish()["status"] == "stopped"
    summary = Simulation(job, tmp_path / "stopped", "pull", restart=True).run()
    assert summary["status"] == "completed"
    ref, got = history(tmp_path / "uninterrupted"), history(tmp_path / "stopped")
    assert ref["fracture_energy_Nmm"][-1] > 0 and ref["stabilisation_energy_Nmm"][-1] > 0
    assert len(got) == len(ref)
    for column in ref.dtype.names:
        if column not in WALL:
            np.testing.assert_allclose(got[column], ref[column], rtol=1e-10, atol=1e-12,
                                       err_msg=column)
