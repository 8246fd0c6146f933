"""Tool surfaces, tool time series, section plots and 3D pictures."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista

from forming.contact.render import ToolSeries, render_3d, section_plot, tool_surface
from forming.contact.shapes import NUMPY, HemisphericalPunch, Plane

PUNCH = HemisphericalPunch((0.0, 0.0, 0.0), 10.0)
BOUNDS = (-15.0, 15.0, -15.0, 15.0, -2.0, 20.0)


def test_tool_surface_is_the_zero_level_set():
    surface = tool_surface(PUNCH, BOUNDS, 0.5)
    points = np.asarray(surface.points)
    assert surface.n_points > 100
    assert np.abs(PUNCH.distance(points.T, NUMPY)).max() < 0.5
    assert np.linalg.norm(points, axis=1).min() < 0.5  # near the tip


def test_tool_surface_outside_box_and_empty_bounds():
    assert tool_surface(PUNCH, (-15, 15, -15, 15, -10, -5), 1.0).n_points == 0
    with pytest.raises(ValueError):
        tool_surface(PUNCH, (0, 0, -1, 1, -1, 1), 1.0)


def test_tool_series_writes_steps_and_collection(tmp_path):
    series = ToolSeries(tmp_path, [("punch", PUNCH)], BOUNDS, 1.0)
    series.write(0, 0.0, {"punch": np.zeros(3)})
    series.write(1, 0.5, {"punch": np.array([0.0, 0.0, -2.0])})
    pvd = (tmp_path / "tool_punch.pvd").read_text()
    for step, t in ((0, 0.0), (1, 0.5)):
        name = f"tools/punch_{step:05d}.vtp"
        assert f'timestep="{t}" part="0" file="{name}"' in pvd
        assert (tmp_path / name).is_file()
    moved = pyvista.read(tmp_path / "tools/punch_00001.vtp")
    assert moved.bounds[4] == pytest.approx(series.surfaces["punch"].bounds[4] - 2.0)


def test_tool_series_writes_a_tool_at_rest_once(tmp_path):
    """A tool that has not moved since its last file is not written again: the
    collection points later steps at that file, which ParaView then shows in place.
    A failure means a fixed die is written at every output (slow, and disk) or a moved
    tool is shown where it was."""
    series = ToolSeries(tmp_path, [("die", Plane((0.0, 0.0, 1.0))), ("punch", PUNCH)],
                        BOUNDS, 1.0)
    for step, z in enumerate((0.0, -1.0, -2.0)):
        series.write(step, 0.5 * step, {"die": np.zeros(3), "punch": np.array([0, 0, z])})
    assert sorted(p.name for p in (tmp_path / "tools").glob("die_*.vtp")) == ["die_00000.vtp"]
    assert len(list((tmp_path / "tools").glob("punch_*.vtp"))) == 3
    pvd = (tmp_path / "tool_die.pvd").read_text()
    for t in (0.0, 0.5, 1.0):
        assert f'timestep="{t}" part="0" file="tools/die_00000.vtp"' in pvd


def test_section_plot_writes_png(tmp_path):
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    polygons = [square, square + [1.0, 0.0]]
    tools = [("platen", Plane((0.0, 0.0, 1.0)), np.zeros(3)),
             ("punch", HemisphericalPunch((0.0, 0.0, 1.0), 1.0), np.array([0.0, 0.0, 0.1]))]
    path = section_plot(tmp_path / "section.png", polygons, np.array([1.0, 2.0]), tools,
                        (1, 0.0), (0, 2), label="stress [MPa]", title="y = 0", mirror=True)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_render_3d_writes_png(tmp_path):
    grid = pyvista.ImageData(dimensions=(4, 4, 4)).cast_to_unstructured_grid()
    grid.cell_data["strain"] = np.linspace(0.0, 1.0, grid.n_cells)
    punch = HemisphericalPunch((1.5, 1.5, 3.5), 1.0)
    path = render_3d(tmp_path / "view.png", grid, "strain", [(punch, np.zeros(3))],
                     (-1.0, 4.0, -1.0, 4.0, 2.0, 7.0), 0.2, title="test")
    assert path.stat().st_size > 1000
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_deformed_grid_draws_only_the_cells_kept():
    """A 2 x 2 x 2 block displaced by u = (0, 0, 0.1 z): the grid holds the kept cells
    only, each with its own cell value and its nodes at x + u. A failure means a picture
    of fractured walls would draw eroded cells (whose drifting nodes make sheets tens of
    millimetres long) or colour the drawn cells with another cell's value.
    """
    from helpers import block_scene

    from forming.materials.library import honeycomb_core
    from forming.model import Model
    from forming.post.pictures import deformed_grid

    model = Model(block_scene(honeycomb_core()))
    body = model.bodies["core"]
    body.u.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], 0.1 * x[2]]))
    n = body.n_local_cells
    keep = np.arange(n) % 3 != 0
    grid = deformed_grid(body, {"index": np.arange(n, dtype=float)}, keep=keep)
    assert grid.n_cells == np.count_nonzero(keep)
    np.testing.assert_array_equal(grid.cell_data["index"], np.flatnonzero(keep))
    # every drawn point sits at 1.1 times its reference height: z' = z + 0.1 z
    heights = np.unique(np.round(grid.points[:, 2], 9))
    np.testing.assert_allclose(heights, [0.0, 5.5, 11.0], atol=1e-9)


def test_a_run_without_pictures_keeps_its_plots_and_data(tmp_path, monkeypatch):
    """``FORMING_PICTURES=0`` (``--no-pictures``) leaves out a case's 3D view and section
    and nothing else: the run's summary, history, fields and force plot are written, and
    its answer is the run's with pictures (the pictures are drawn after the metrics). A
    value other than 1 or 0 is refused before the run starts, naming the variable. A
    failure means the switch drops data with the pictures, or a typo silently skips them.
    """
    import argparse
    import json
    import os

    from forming.case import apply_picture_choice, run_case
    from forming.errors import InputError

    sets = ["cells=2,2,2", "stroke=0.1"]
    monkeypatch.setenv("FORMING_PICTURES", "1")
    drawn = run_case("core_crushing", tmp_path / "drawn", sets)
    monkeypatch.setenv("FORMING_PICTURES", "0")
    plain = run_case("core_crushing", tmp_path / "plain", sets)
    assert {"section_plastic_strain.png", "plastic_strain_3d.png"} <= set(drawn["outputs"])
    assert set(drawn["outputs"]) - set(plain["outputs"]) == {
        "section_plastic_strain.png", "plastic_strain_3d.png"}
    for name in plain["outputs"]:
        assert (tmp_path / "plain" / name).exists(), name
    assert not (tmp_path / "plain" / "plastic_strain_3d.png").exists()
    assert drawn["timing"]["pictures_s"] > 0.0 and plain["timing"]["pictures_s"] >= 0.0
    assert json.loads((tmp_path / "plain" / "summary.json").read_text())["metrics"] \
        == plain["metrics"] == drawn["metrics"]
    monkeypatch.setenv("FORMING_PICTURES", "maybe")
    with pytest.raises(InputError, match="FORMING_PICTURES"):
        run_case("core_crushing", tmp_path / "typo", sets)
    assert not (tmp_path / "typo" / "summary.json").exists()
    monkeypatch.setenv("FORMING_PICTURES", "1")
    apply_picture_choice(argparse.Namespace(no_pictures=True))
    assert os.environ["FORMING_PICTURES"] == "0"
