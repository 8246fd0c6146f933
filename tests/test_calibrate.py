"""Meso to macro: ``forming calibrate`` writes a C365 curve the macro core reproduces."""

from __future__ import annotations

import json

import numpy as np
import pytest

from forming.calibrate import BAND, calibrate, elastic_line, representable
from forming.materials.library import honeycomb_core


def test_calibrated_curve_is_reproduced_by_the_macro_core(tmp_path):
    """A 1 x 1 meso patch (10 mm, 3 layers) compressed past its walls' buckling (3%);
    the macro ``core_compression`` run with the calibrated curve and modulus reproduces
    the calibrated curve and the meso run's own curve within 1% relative RMS (issue 20).

    A failure means the curve conversion (the elastic line, the foam's elastic band)
    or the macro core's reading of a user curve and modulus changed.
    """
    r = calibrate("meso_compression", tmp_path,
                  ["cells=1,1", "height=10", "layers=3", "strain=0.03", "max_step=0.25"],
                  with_moduli=False)
    assert r["meso_status"] == "completed" and r["check_status"] == "completed"
    assert r["buckling_onset_strain"] < 0.03  # the curve has a post-buckling part
    assert r["check_rmse_rel"] < 0.01
    assert r["macro_against_meso_rmse_rel"] < 0.01
    assert r["largest_change_before_onset_rel"] < BAND
    # the written curve is what the macro core reads, with the meso run's modulus
    core = honeycomb_core("transverse", curve=r["curve"], E_through=r["modulus_MPa"],
                          elastic_band=BAND)
    assert core.curve.strain[-1] == pytest.approx(0.03)
    saved = json.loads((tmp_path / "calibration.json").read_text())
    assert saved["use"].startswith("forming run core_compression --set curve=")
    assert (tmp_path / "calibration.png").is_file()


def test_representable_keeps_softening_and_cuts_a_stiffening():
    """After yield a curve may fall as steeply as it likes (its plastic strain grows):
    the drop when walls break is kept; closely spaced points are merged. A rise steeper
    than the elastic line (the plastic strain would decrease) is cut before it. A failure
    means the macro core would be handed a curve it refuses, or a usable one cut."""
    e = np.array([0.0, 0.005, 0.01, 0.02, 0.03, 0.04, 0.04001, 0.041, 0.05])
    s = elastic_line(e, 30.0)
    s[3:] = [0.55, 0.6, 0.62, 0.62, 0.30, 0.31]  # yield, then walls break at 0.041
    ek, sk, why = representable(e, s, 30.0)
    assert ek.size == 8 and why == ""  # 0.04001 merged into 0.04
    s[8] = 0.30 + 40.0 * 0.009  # rises at 40 MPa > 30 MPa after the drop
    ek, sk, why = representable(e, s, 30.0)
    assert ek[-1] == pytest.approx(0.041) and "cut after strain 0.041" in why
    assert "strain 0.05" in why  # the foam names the point it refuses


def test_calibrate_refuses_a_macro_case(tmp_path):
    """``forming calibrate`` names itself when asked to calibrate from a case that is not
    a meso case (an input error, before anything runs)."""
    from forming.errors import InputError

    with pytest.raises(InputError, match="calibrate"):
        calibrate("core_compression", tmp_path, [])
    assert not (tmp_path / "meso").exists()


def test_shear_needs_bonded_platens(tmp_path):
    """A transverse shear run names ``--set load`` when its platens only touch the walls
    (a touching platen cannot carry shear without friction)."""
    from forming.case import run_case
    from forming.errors import InputError

    with pytest.raises(InputError, match="load"):
        run_case("meso_compression", tmp_path, ["load=shear_x", "platen=contact"])
