"""Runs that cannot mean anything are refused; suspect ones complete with a warning."""

from __future__ import annotations

import dataclasses
import json

import pytest
from helpers import block_scene

from forming.case import prepare_case, run_case
from forming.compare import compare
from forming.contact.shapes import Plane
from forming.errors import InputError
from forming.job import Job
from forming.materials.library import honeycomb_core
from forming.run import simulate
from forming.scene import Contact, Tool
from forming.simulation import Simulation

COARSE = ["cells=4,4,2", "stroke=1.5"]


@pytest.mark.parametrize(("case", "setting", "key"), [
    ("core_compression", "strain=0", "strain"),
    ("core_compression", "strain=1.2", "strain"),
    ("hemisphere", "stroke=-10", "stroke"),
    ("hemisphere", "punch_diameter=150", "punch_diameter"),
    ("core_crushing", "stroke=0", "stroke"),
    ("core_crushing", "friction=-0.1", "friction"),
    ("skin_sled", "drag=0", "drag"),
])
def test_meaningless_parameters_are_refused(tmp_path, case, setting, key):
    """Zero or negative strokes and strains, a punch wider than the die: refused before
    anything runs, naming the key the user typed."""
    with pytest.raises(InputError, match=rf"^--set {key}: "):
        run_case(case, tmp_path, [setting])
    assert not any(tmp_path.iterdir())


def test_a_curve_shorter_than_the_run_is_refused_unless_asked(tmp_path):
    """core_compression to 0.9 strain on a curve that ends at 0.5: refused (the curve
    would be extrapolated silently); --set extrapolate=true runs it and warns."""
    csv = tmp_path / "short.csv"
    csv.write_text("strain,stress\n0,0\n0.02,0.3\n0.1,0.26\n0.3,0.25\n0.5,0.27\n")
    with pytest.raises(InputError, match=r"--set strain: 0.9 passes the last point .*0.5"):
        run_case("core_compression", tmp_path / "a", [f"curve={csv}"])
    s = run_case("core_compression", tmp_path / "b", [f"curve={csv}", "extrapolate=true"])
    assert s["status"] == "completed"
    assert any("passed the last point of its compression curve" in w for w in s["warnings"])


def test_a_tool_inside_the_blank_at_the_start_is_refused(tmp_path):
    """A platen that starts 1 mm inside the block's top face: refused, naming the tool."""
    scene = dataclasses.replace(
        block_scene(honeycomb_core("isotropic")),
        tools=(Tool("platen", Plane((0.0, 0.0, 9.0), (0.0, 0.0, -1.0))),),
        contacts=(Contact("core", "top", "platen"),))
    with pytest.raises(InputError, match=r"tools: tool platen overlaps core by 1 mm"):
        simulate(Job(scene=scene), tmp_path, "overlap", {})


def test_friction_above_one_completes_with_a_warning(tmp_path):
    """Friction 1.5 is accepted (a user may want it) but flagged in summary.json (two
    steps of the sled, then stopped)."""
    sim = Simulation(prepare_case("skin_sled", ["friction=1.5"])[0], tmp_path, "sled")
    sim.step()
    s = sim.finish()
    assert s["status"] == "stopped"
    assert any("interface_top: friction 1.5 is above 1" in w for w in s["warnings"])


def test_a_fast_explicit_run_is_flagged_not_quasi_static(tmp_path):
    """An explicit run loaded in 0.5 ms (far below the core's lowest period) is not
    quasi-static: a warning, valid false, and a compare verdict that fails."""
    s = run_case("core_crushing", tmp_path, [*COARSE, "solver=explicit",
                                             "explicit.loading_time=0.0005"])
    assert s["status"] == "completed"
    assert s["validity"]["quasi_static"] is False and s["valid"] is False
    assert any("kinetic energy reached" in w for w in s["warnings"])


def test_added_mass_above_five_percent_is_flagged(tmp_path):
    """Mass scaling to a 1e-4 s time step adds far more than 5% of the mass: flagged."""
    s = run_case("core_crushing", tmp_path, [*COARSE, "solver=explicit",
                                             "explicit.loading_time=0.01",
                                             "explicit.target_time_step=1e-4"])
    assert s["metrics"]["mass_added_fraction"] > 0.05
    assert s["validity"]["mass_added_below_limit"] is False
    assert any("mass scaling added" in w for w in s["warnings"])


def test_undefined_metrics_are_null_with_a_reason(tmp_path):
    """core_compression to 0.05 strain has no plateau: the plateau stress is null in
    summary.json (never the string "nan") and metric_notes says why."""
    s = run_case("core_compression", tmp_path, ["strain=0.05"])
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["metrics"]["plateau_stress_MPa"] is None
    assert "not defined" in on_disk["metric_notes"]["plateau_stress_MPa"]
    assert s["valid"] is True  # the curve is still reproduced


def test_compare_verdict_needs_each_run_valid(tmp_path):
    """A compare whose explicit run misses its own curve check does not meet its targets,
    even where force and shape agree (the explicit core_compression at 0.5 ms)."""
    r = compare("core_compression", tmp_path, ["strain=0.3", "explicit.loading_time=0.0005"])
    assert r["valid_implicit"] is True
    assert r["valid_explicit"] is False and r["meets_targets"] is False
    assert "failed" in (tmp_path / "report.md").read_text()


def test_crushing_metrics_are_consistent(tmp_path):
    """The largest crushing strain is at least the mean crushing strain under the punch
    (both pointwise now; the cell-mean maximum fell below the mean on coarse meshes)."""
    s = run_case("hemisphere", tmp_path, ["cells=6,6,2", "stroke=8", "blank_holder=true"])
    m = s["metrics"]
    assert m["crushing_strain_max"] >= m["crushing_strain_mean_under_punch"] > 0
    assert m["crushed_volume_under_punch_mm3"] <= m["crushed_volume_mm3"]


def test_small_sliding_beyond_its_range_is_warned(tmp_path):
    """A sled pulled 6 mm over 10 mm facets passes the small-sliding limit (half a facet):
    the run completes, and summary.json warns that the pairing loses accuracy."""
    s = run_case("skin_sled", tmp_path, ["drag=6"])
    assert s["status"] == "completed"
    assert any("interface interface_top: slip" in w and "small-sliding" in w
               for w in s["warnings"])
