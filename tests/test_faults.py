"""Runs that survive interrupts, kills, failing case code, used folders and MPI errors."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import REPO, block_scene, history, run_mpi

from forming.errors import EXIT_CODES, InputError
from forming.fields import FieldSeries
from forming.job import Job
from forming.materials.library import honeycomb_core
from forming.run import simulate

LONG_RUN = ["cases/hemisphere.py", "--set", "cells=8,8,2", "--set", "blank_holder=true"]


def _start(out: Path) -> subprocess.Popen:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.Popen([sys.executable, *LONG_RUN, "--out", str(out)], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_rows(proc: subprocess.Popen, out: Path, rows: int, timeout: float = 120) -> None:
    """Wait until the run has written ``rows`` history rows (and is still running)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        path = out / "history.csv"
        if path.is_file() and len(path.read_text().splitlines()) > rows:
            return
        if proc.poll() is not None:
            pytest.fail(f"run ended early: {proc.stderr.read()[-2000:]}")
        time.sleep(0.2)
    proc.kill()
    pytest.fail("the run wrote no history in time")


def _final_shape_matches_fields(out: Path) -> None:
    """The last displacement in the ParaView file is the one of final_shape.npz."""
    series = FieldSeries(out / "displacement.bp")
    X, u = series.points(), series.values("u")
    order = np.lexsort(np.round(X, 9).T[::-1])
    with np.load(out / "final_shape.npz") as z:
        np.testing.assert_allclose(X[order], z["core_X"], atol=1e-9)
        np.testing.assert_array_equal(u[order], z["core_u"])
    h = history(out)
    assert series.times[-1] == pytest.approx(h["t"][-1], abs=1e-12)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_signal_ends_the_run_cleanly(tmp_path, sig):
    """SIGINT (Ctrl-C) and SIGTERM (a scheduler's stop) mid-run: status interrupted with the
    stroke reached, exit code 130 / 143, the last converged state in the fields, history
    and final shape, and the plots of the partial run.

    A failure means PETSc's handler took the signal (error 73, status failed), or the run
    died without closing its output.
    """
    proc = _start(tmp_path)
    _wait_for_rows(proc, tmp_path, 4)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    name = signal.Signals(sig).name
    assert proc.returncode == EXIT_CODES[name], err[-2000:]
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["signal"] == name
    assert "stroke" in s["reason"] and 0 < s["load_parameter_reached"] < 1
    h = history(tmp_path)
    assert h["t"][-1] == s["load_parameter_reached"] and h["step"][-1] == s["timing"]["steps"]
    _final_shape_matches_fields(tmp_path)
    assert (tmp_path / "punch_force.png").is_file()


def test_a_killed_run_is_recognisable(tmp_path):
    """SIGKILL cannot be caught: summary.json still says running (written at the start,
    with the command line), and history.csv holds whole rows (written atomically)."""
    proc = _start(tmp_path)
    _wait_for_rows(proc, tmp_path, 3)
    proc.kill()
    proc.communicate(timeout=60)
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["status"] == "running"
    assert "hemisphere.py" in s["run"]["command"] and s["run"]["started"]
    h = history(tmp_path)
    assert len(h) >= 3 and np.all(np.isfinite(h["force_punch_z_N"]))


def test_a_case_metric_that_raises_fails_the_run_but_keeps_it(tmp_path):
    """An exception in a case's metrics: status failed with the exception in the reason,
    and the converged fields, history and final shape on disk."""
    def broken(rec, model):
        raise ZeroDivisionError("metric divides by zero")

    job = Job(scene=block_scene(honeycomb_core("isotropic")), metrics=broken)
    s = simulate(job, tmp_path, "broken", {})
    assert s["status"] == "failed"
    assert "metrics raised ZeroDivisionError: metric divides by zero" in s["reason"]
    assert s["load_parameter_reached"] == 1.0
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "failed"
    assert (tmp_path / "final_shape.npz").is_file() and len(history(tmp_path)) > 1


def test_a_rerun_clears_the_earlier_run_and_a_foreign_folder_is_refused(tmp_path):
    """A run into a folder with an earlier run replaces its files (no stale PNG or field
    stays); a non-empty folder that holds no run, or a file, is refused by name."""
    job = Job(scene=block_scene(honeycomb_core("isotropic")))
    (tmp_path / "run").mkdir()
    simulate(job, tmp_path / "run", "first", {})
    stale = tmp_path / "run" / "stale_plot.png"
    stale.write_bytes(b"old")
    s = simulate(job, tmp_path / "run", "second", {})
    assert s["case"] == "second" and not stale.exists()
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["case"] == "second"
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("my data")
    with pytest.raises(InputError, match="holds no earlier run"):
        simulate(job, tmp_path / "mine", "third", {})
    assert (tmp_path / "mine" / "notes.txt").read_text() == "my data"
    (tmp_path / "afile").write_text("x")
    with pytest.raises(InputError, match="is a file"):
        simulate(job, tmp_path / "afile", "fourth", {})


@pytest.mark.mpi
def test_two_ranks_bad_output_path_exits_promptly(tmp_path):
    """mpirun -n 2 with --out naming a file: every rank ends, within 30 s, with the
    bad-input exit code and a message naming the path (it used to hang rank 1)."""
    target = tmp_path / "afile"
    target.write_text("x")
    proc = run_mpi(["cases/core_tension.py", "--out", str(target)], timeout=30)
    assert proc.returncode == EXIT_CODES["input"], proc.stderr[-2000:]
    assert f"{target} is a file" in proc.stderr


@pytest.mark.mpi
def test_two_ranks_error_on_one_rank_exits_promptly(tmp_path):
    """An error raised on rank 1 only (a case that cannot read its input there) ends
    both ranks within 30 s with the bad-input exit code."""
    script = tmp_path / "one_rank.py"
    script.write_text(
        "import dataclasses, sys\n"
        "from mpi4py import MPI\n"
        "from forming.case import main\n"
        "from forming.errors import InputError\n"
        "@dataclasses.dataclass(frozen=True)\n"
        "class Params:\n"
        "    size: float = 1.0  # size\n"
        "def build(p):\n"
        "    if MPI.COMM_WORLD.rank == 1:\n"
        "        raise InputError('curve', 'cannot read the curve on rank 1')\n"
        "    MPI.COMM_WORLD.barrier()  # rank 0 would wait here for ever\n"
        "main(build, Params, 'one_rank')\n")
    proc = run_mpi([str(script), "--out", str(tmp_path / "out")], timeout=30)
    assert proc.returncode == EXIT_CODES["input"], proc.stderr[-2000:]
    assert "cannot read the curve on rank 1" in proc.stderr


@pytest.mark.mpi
def test_an_error_of_the_meshing_rank_is_raised_on_every_rank(tmp_path):
    """Meshes and tool files are made on rank 0 while the other ranks wait for them: an
    error there (a file gmsh cannot read, a failure of the meshing code) is raised on
    every rank, as the same ``InputError`` with its field, or as a ``RuntimeError`` that
    names it, so a script that calls the library under mpirun neither hangs nor leaves
    the other ranks without the reason. A failure means a rank-0 block that keeps its
    error to itself (forming.parallel.on_root)."""
    garbage = tmp_path / "garbage.msh"
    garbage.write_text("not a mesh\n")
    script = tmp_path / "root_errors.py"
    script.write_text(
        "import sys\n"
        "from mpi4py import MPI\n"
        "import forming\n"
        "from forming.errors import InputError\n"
        "from forming.mesh import from_file\n"
        "from forming.parallel import on_root\n"
        "rank = MPI.COMM_WORLD.rank\n"
        "try:\n"
        f"    from_file({str(garbage)!r})\n"
        "except InputError as exc:\n"
        "    print(f'rank {rank} input {exc.field}', flush=True)\n"
        "def broken():\n"
        "    raise KeyError('lost')\n"
        "try:\n"
        "    on_root(MPI.COMM_WORLD, broken)\n"
        "except RuntimeError as exc:\n"
        "    print(f'rank {rank} runtime {exc}', flush=True)\n"
        "print(f'rank {rank} result {on_root(MPI.COMM_WORLD, lambda: 7)}', flush=True)\n")
    proc = run_mpi([str(script)], timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for rank in (0, 1):
        assert f"rank {rank} input mesh.path" in proc.stdout
        assert f"rank {rank} runtime KeyError('lost') on rank 0" in proc.stdout
    assert "rank 0 result 7" in proc.stdout and "rank 1 result None" in proc.stdout


def test_an_inverted_element_is_reported_with_its_body_and_place():
    """A step that inverts an element fails with the body's name and where the first
    inverted point is (the cell's centre), so a user sees which part folded through
    itself (a soft dummy flange, say) instead of a bare count. A failure means the
    message lost the body or the place (forming/bodies/solid.py)."""
    from forming.errors import KernelFailure
    from forming.model import Model

    scene = block_scene(honeycomb_core("isotropic"), cells=(2, 2, 2))
    body = Model(scene).bodies["core"]
    x = body.V.tabulate_dof_coordinates()
    u = body.u.x.array.reshape(-1, 3)
    corner = np.linalg.norm(x - [10.0, 10.0, 10.0], axis=1) < 1e-9
    u[corner, 2] = -12.0  # the top corner node pushed through the bottom of its cell
    with pytest.raises(KernelFailure, match=r"in body 'core', the first in the cell at "
                                            r"\(7\.5, 7\.5, 7\.5\) mm"):
        body.update_material()


def test_an_inverted_fabric_element_is_named_in_the_failed_step_s_reason(tmp_path):
    """A fabric's stress is a UFL form with ``ln det F`` in it: a Newton iterate that
    inverts a point of a skin makes the residual NaN with no kernel to say why. A fabric
    cube pressed down 15 mm of its 10 mm height in one step: the start is finite, the
    first Newton step inverts it, and the step's reason names the body and its smallest
    det F at the full rule's points. A failure means such steps fail with a bare
    DIVERGED_FUNCTION_NANORINF again (most of the demonstrator's cut-backs with weak
    skin springs were these, docs/theory.md §16), or the diagnosis looks at a state other
    than the one that went NaN."""
    from forming.materials.fabric import NonCrimpFabric
    from forming.simulation import Simulation
    from forming.solver.stepping import StepControl

    job = Job(scene=block_scene(NonCrimpFabric(), cells=(2, 2, 2), stroke=-15.0),
              steps=StepControl(initial=1.0, max=1.0, min=0.5))
    result = Simulation(job, tmp_path, case="block").step()
    assert not result.converged and np.isfinite(result.residuals[0])
    assert "inverted elements (det F <= 0) in body 'core' (det F down to -0." in result.reason
