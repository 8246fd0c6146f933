"""Partitions of the mesh among ranks (:mod:`forming.partition`).

The wedge partition moves work between ranks, never the answer: an explicit run of the
square punch on 2 ranks gives the graph partition's force curve to round-off.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import history, run_mpi

from forming.case import prepare_case, resolve_partition
from forming.errors import InputError
from forming.partition import check, wedge_owners


def test_wedge_owners_are_equal_sectors():
    """Sectors hold equal cell counts (within one) and follow each other in angle.

    A failure means a rank receives more cells than its share, or sectors interleave
    (a rank holding cells on both sides of another: a longer cut than a wedge's).
    """
    rng = np.random.default_rng(3)
    pts = rng.uniform(0.0, 150.0, size=(1001, 3))
    angle = np.arctan2(pts[:, 1], pts[:, 0])
    for nparts in (1, 2, 3, 4):
        owners = wedge_owners(pts, nparts)
        counts = np.bincount(owners, minlength=nparts)
        assert counts.max() - counts.min() <= 1
        bounds = [(angle[owners == r].min(), angle[owners == r].max()) for r in range(nparts)]
        assert all(bounds[r][1] <= bounds[r + 1][0] for r in range(nparts - 1))
    # two ranks on a square quarter: the cut is the diagonal
    owners = wedge_owners(pts, 2)
    assert np.all(angle[owners == 0] <= np.pi / 4 + 0.05)
    assert np.all(angle[owners == 1] >= np.pi / 4 - 0.05)


def test_partition_setting_resolves_by_solver():
    """``partition=auto`` is the wedge for an explicit run and the graph otherwise; an
    unknown partition is an error naming the field."""
    job, params = prepare_case("core_crushing", ["cells=2,2,1", "solver=explicit"])
    assert params["partition"] == "wedge"
    _job, params = prepare_case("core_crushing", ["cells=2,2,1"])
    assert params["partition"] == "graph"
    assert resolve_partition(job, "explicit") is job  # no partition field: unchanged
    with pytest.raises(InputError, match="partition"):
        check("spiral")


@pytest.mark.mpi
def test_wedge_partition_keeps_the_explicit_answer(tmp_path, repo):
    """Square punch, explicit, 2 ranks: the wedge and graph partitions give the same punch
    force history to 1e-8 relative (sums in another order: round-off only).

    A failure means a partition changes the physics: a cell, ghost or contact node lost
    or counted twice at the sector boundary.
    """
    script = (
        "import sys\nfrom pathlib import Path\nfrom forming.case import run_case\n"
        "for part in ('graph', 'wedge'):\n"
        "    run_case('core_crushing', Path(sys.argv[1]) / part, ['cells=4,4,2', "
        "'solver=explicit', 'explicit.loading_time=0.002', 'stroke=4', "
        "f'partition={part}'])\n")
    proc = run_mpi(["-c", script, str(tmp_path)])
    assert proc.returncode == 0, proc.stderr[-3000:]
    runs = {}
    for part in ("graph", "wedge"):
        summary = json.loads((tmp_path / part / "summary.json").read_text())
        assert summary["status"] == "completed" and summary["ranks"] == 2
        assert summary["parameters"]["partition"] == part
        runs[part] = history(tmp_path / part)["force_punch_z_N"]
    a, b = runs["graph"], runs["wedge"]
    assert a.size == b.size and np.max(np.abs(a)) > 100.0
    assert np.max(np.abs(b - a)) <= 1e-8 * np.max(np.abs(a))
