"""Parameter studies (``forming study``) and the convergence judgement they rely on."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from forming.errors import InputError
from forming.post.convergence import (
    convergence_kind,
    extrapolate,
    observed_order,
    pareto_front,
    why_not,
)
from forming.study import Vary, folder_name, parse_study


@pytest.mark.parametrize("h", [(1.0, 2.0, 4.0), (1.0, 1.3, 2.0), (0.5, 0.9, 1.0)])
@pytest.mark.parametrize("p", [1.0, 2.0, 3.5])
def test_richardson_recovers_an_exact_power_law(h, p):
    """For ``f = 1 + 0.3 h^p`` on three sizes, equal or unequal ratios, the observed order
    is ``p`` and the extrapolated value is 1, to 1e-9; the GCI of the finest level is
    1.25 times its true relative error. A failure means the fixed point of Celik et al.
    (2008) or the extrapolation formula is wrong."""
    f = [1.0 + 0.3 * x ** p for x in h]
    assert observed_order(h, f) == pytest.approx(p, abs=1e-9)
    e = extrapolate(list(reversed(h)), list(reversed(f)))  # any order of levels
    assert e.order == pytest.approx(p, abs=1e-9)
    assert e.value == pytest.approx(1.0, abs=1e-9)
    true_error = abs(f[0] - 1.0) / f[0]
    assert e.gci == pytest.approx(1.25 * true_error, rel=1e-6)


def test_richardson_refuses_what_it_cannot_judge():
    """Oscillating, stalled, diverging or too slowly converging levels (order below 0.5),
    fewer than three levels, or equal sizes give no extrapolation (None), the order
    function raises where no positive order fits, and why_not says which."""
    assert convergence_kind([1.0, 1.1, 1.0]) == "oscillating"
    assert convergence_kind([1.0, 1.0, 1.2]) == "converged"
    assert extrapolate([1, 2, 4], [1.0, 1.1, 1.0]) is None
    assert extrapolate([1, 2], [1.0, 1.1]) is None
    assert extrapolate([1, 1, 2], [1.0, 1.1, 1.3]) is None
    with pytest.raises(ValueError, match="oscillating"):
        observed_order([1, 2, 4], [1.0, 1.1, 1.0])
    with pytest.raises(ValueError, match="grow"):
        observed_order([2, 1, 4], [1.0, 1.1, 1.3])
    # monotonic, but changing more on the finer levels: no positive order fits (the fixed
    # point with absolute values of Celik et al. returns one anyway)
    with pytest.raises(ValueError, match="no positive order"):
        observed_order([1, 2, 4], [1.0, 1.5, 1.7])
    assert extrapolate([1, 2, 4], [1.0, 1.5, 1.7]) is None
    assert "change more" in why_not([1, 2, 4], [1.0, 1.5, 1.7])
    assert "oscillate" in why_not([4, 2, 1], [1.0, 1.1, 1.0])
    # converging, but too slowly to be in the asymptotic range: core_shear's modulus on
    # 24x1x2, 48x2x4, 96x4x8 drifts by 0.2% per level (order 0.06; Richardson would put
    # the limit 5% away from every level)
    shear = [1.55953, 1.5562, 1.55299]
    assert observed_order([1, 2, 4], shear[::-1]) < 0.1
    assert extrapolate([4, 2, 1], shear) is None
    assert "too slowly" in why_not([4, 2, 1], shear)


def test_pareto_front():
    """The front keeps the runs no other run beats in both cost and error, cheapest first."""
    cost = [1.0, 2.0, 3.0, 4.0, 2.5]
    error = [0.1, 0.05, 0.2, 0.01, 0.05]
    assert pareto_front(cost, error) == [0, 1, 3]


def test_vary_and_study_inputs(tmp_path):
    """Levels split at ',' or, when they hold commas or the parameter is a tuple, at ':';
    bad input names the option."""
    assert Vary.parse("max_step=0.02,0.01").values == ("0.02", "0.01")
    assert Vary.parse("cells=8,8,2:12,12,3").values == ("8,8,2", "12,12,3")
    # a tuple parameter's single level keeps its commas
    assert parse_study("hemisphere", ["cells=12,12,3"], tmp_path).varies[0].values == (
        "12,12,3",)
    assert folder_name({"cells": "8,8,2", "max_step": "0.01"}) == "cells-8-8-2_max_step-0.01"
    for bad in ("cells", "=1,2", "a=1,,2", "a=1,1"):
        with pytest.raises(InputError, match="--vary"):
            Vary.parse(bad)
    with pytest.raises(InputError, match="unknown case"):
        parse_study("no_such_case", ["a=1,2"], tmp_path)
    with pytest.raises(InputError, match="no parameter 'thickness_of_nothing'"):
        parse_study("ironing", ["thickness_of_nothing=1,2"], tmp_path)
    assert parse_study("ironing", ["solver=implicit,explicit", "newton.max_it=10,20"],
                       tmp_path).combinations()[1] == {"solver": "implicit",
                                                       "newton.max_it": "20"}
    with pytest.raises(InputError, match="both set and varied"):
        parse_study("ironing", ["slide=10,20"], tmp_path, sets=["slide=5"])
    with pytest.raises(InputError, match="--reference"):
        parse_study("ironing", ["slide=10,20"], tmp_path, reference="best")


def _study(out, levels):
    cmd = [sys.executable, "-m", "forming.cli", "study", "ironing",
           "--vary", f"block_element={levels}", "--set", "die_cells=16", "--set", "slide=8",
           "--set", "max_step=0.05", "--metric", "normal_force_mean_N", "--out", str(out),
           "--quiet"]
    return subprocess.run(cmd, capture_output=True, text=True)


def test_study_runs_reuses_and_reports_failures(tmp_path):
    """``forming study ironing --vary block_element=6,5,4,-1`` on a short slide: the
    three valid levels complete and the bad one (-1 mm) is a row with status ``error``
    (the study goes on, exit code 1); ``study.csv``, ``study.md`` and the PNGs are written,
    the normal force's order is observed over the three levels, and rerunning with one
    more level runs that level only (the others are reused, their rows unchanged). The
    representative size is the element size itself (the unknowns fall as it grows)."""
    out = tmp_path / "study"
    first = _study(out, "6,5,4,-1")
    assert first.returncode == 1, first.stderr[-2000:]
    rows = list(csv.DictReader(open(out / "study.csv")))
    assert [r["status"] for r in rows] == ["completed"] * 3 + ["error"]
    assert "block_element" in rows[3]["reason"] or "exit code 2" in rows[3]["reason"]
    for name in ("study.md", "normal_force_mean_N.png",
                 "error_vs_time_normal_force_mean_N.png"):
        assert (out / name).is_file(), name
    unknowns = [int(r["unknowns"]) for r in rows[:3]]
    assert unknowns[0] < unknowns[1] < unknowns[2]
    md = (out / "study.md").read_text()
    assert "observed order" in md or "no extrapolation" in md

    second = _study(out, "6,5,4,8")
    assert second.returncode == 0, second.stderr[-2000:]
    again = list(csv.DictReader(open(out / "study.csv")))
    assert [r["reused"] for r in again] == ["True", "True", "True", "False"]
    for a, b in zip(rows[:3], again[:3], strict=True):
        assert a["normal_force_mean_N"] == b["normal_force_mean_N"]
    s = json.loads((out / "runs" / "block_element-8" / "summary.json").read_text())
    assert s["status"] == "completed"
    forces = np.array([float(r["normal_force_mean_N"]) for r in again])
    assert np.all(np.isfinite(forces)) and not math.isclose(forces[0], forces[3])


def test_a_drape_study_converges_to_the_punch_and_reuses_its_levels(tmp_path):
    """``forming study hemisphere --drape --vary drape.spacing=...``: each level is a
    ``forming drape`` whose ``summary.json`` the study tabulates like a run's. The net stops
    at the punch's equator (where the blank cannot reach), so its draped area tends to the
    hemisphere's, 2 pi R^2 with R = 50 mm, from below as the spacing falls, at first order
    (the cells cut at the equator, a band about one cell wide, are left out): the shortfall
    halves with the spacing (ratios 1.6 to 2.4; measured 1.84, 1.83) and is within 6% at
    3.4 mm (measured 5.5%). Rerun with a finer level, the three are reused. A failure means
    drape studies misread their levels or the net's coverage."""
    out = tmp_path / "drape_study"

    def study(levels: str):
        cmd = [sys.executable, "-m", "forming.cli", "study", "hemisphere", "--drape",
               "--vary", f"drape.spacing={levels}", "--metric", "draped_area_mm2",
               "--metric", "shear_max_deg", "--out", str(out), "--quiet"]
        return subprocess.run(cmd, capture_output=True, text=True)

    first = study("13.6,6.8,3.4")
    assert first.returncode == 0, first.stderr[-2000:]
    rows = list(csv.DictReader(open(out / "study.csv")))
    assert [r["status"] for r in rows] == ["completed"] * 3
    hemisphere = 2 * math.pi * 50.0**2
    area = np.array([float(r["draped_area_mm2"]) for r in rows])
    short = hemisphere - area
    assert np.all(short > 0)
    assert np.all((short[:-1] / short[1:] > 1.6) & (short[:-1] / short[1:] < 2.4))
    assert short[-1] < 0.06 * hemisphere
    assert (out / "draped_area_mm2.png").is_file()
    second = study("13.6,6.8,3.4,2.4")
    assert second.returncode == 0, second.stderr[-2000:]
    again = list(csv.DictReader(open(out / "study.csv")))
    assert [r["reused"] for r in again] == ["True", "True", "True", "False"]


def test_drape_settings_through_set_and_their_errors(tmp_path):
    """``--set drape.spacing=...`` is the drape's ``--spacing``; an unknown drape setting,
    one given both ways and a drape setting varied without ``--drape`` are refused,
    naming the option."""
    from forming.drape_case import drape_settings

    sets, opts = drape_settings(["skins=true", "drape.spacing=4", "drape.tool=punch"],
                                {"spacing": None, "tool": None, "angle": 30.0})
    assert sets == ["skins=true"]
    assert opts == {"spacing": 4.0, "tool": "punch", "angle": 30.0}
    with pytest.raises(InputError, match="no setting 'colour'"):
        drape_settings(["drape.colour=red"], {})
    with pytest.raises(InputError, match="given twice"):
        drape_settings(["drape.spacing=4"], {"spacing": 2.0})
    with pytest.raises(InputError, match="expected a number"):
        drape_settings(["drape.angle=steep"], {})
    with pytest.raises(InputError, match="need --drape"):
        parse_study("hemisphere", ["drape.spacing=4,2"], tmp_path)
    with pytest.raises(InputError, match="one process"):
        parse_study("hemisphere", ["drape.spacing=4,2"], tmp_path, ranks=2, drape=True)
