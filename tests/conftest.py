"""Shared fixtures. Importing forming.compat first loads PETSc the right way."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import forming.compat  # noqa: F401

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


def run_mpi(args: list[str], n: int = 2, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run ``python args`` under ``mpirun -n n`` with the venv's MPI."""
    mpirun = Path(sys.executable).parent / "mpirun"
    cmd = [str(mpirun), "-n", str(n), sys.executable, *args]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)
