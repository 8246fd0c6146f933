"""The implicit-versus-explicit comparison (``forming compare``): its measures and errors.

The end-to-end comparison runs in tests/test_explicit.py (square-punch crushing).
"""

from __future__ import annotations

import numpy as np
import pytest

from forming.compare import compare, force_differences, reference_thickness, shape_differences
from forming.errors import InputError


def test_force_differences_of_known_curves():
    """A constant offset c of the explicit curve gives an RMS and a final difference of
    c / peak; the peak difference is taken at the explicit abscissae (an interval mean
    cannot reach a peak at the end of the stroke)."""
    xi = np.linspace(0.0, 10.0, 21)
    fi = 100.0 * xi  # peak 1000 at the end
    xe = np.linspace(0.25, 9.75, 20)  # interval midpoints
    fe = 100.0 * xe + 20.0
    d = force_differences((xi, fi), (xe, fe))
    assert d["force_rms_diff_rel"] == pytest.approx(0.02)
    assert d["force_max_diff_rel"] == pytest.approx(0.02)
    assert d["final_force_diff_rel"] == pytest.approx(0.02)
    assert d["peak_force_implicit_N"] == pytest.approx(1000.0)
    assert d["peak_force_diff_rel"] == pytest.approx(20.0 / 975.0)


def test_force_differences_reject_a_zero_reference():
    x = np.linspace(0, 1, 5)
    with pytest.raises(InputError, match="response"):
        force_differences((x, 0 * x), (x, x))


def test_shape_differences_measure_nodal_distance_over_thickness():
    """Two bodies: the RMS runs over all nodes; the thickness is the core's z extent.

    The distance splits into its part along z and in plan; a failure means a node's
    move is counted in the wrong part (or twice).
    """
    X = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 20.0], [1, 0, 20.0]])
    u = np.zeros((4, 3))
    imp = {"core_X": X, "core_u": u, "skin_X": X[:2], "skin_u": u[:2]}
    moved = u.copy()
    moved[:, 2] = 0.4  # every core node 0.4 mm off
    exp = {"core_X": X, "core_u": moved, "skin_X": X[:2], "skin_u": u[:2]}
    h = reference_thickness(imp)
    assert h == pytest.approx(20.0)
    fig, dist = shape_differences(imp, exp, h)
    assert fig["shape_max_diff_mm"] == pytest.approx(0.4)
    assert fig["shape_rms_diff_mm"] == pytest.approx(0.4 * np.sqrt(4 / 6))
    assert fig["shape_rms_diff_rel_thickness"] == pytest.approx(0.4 * np.sqrt(4 / 6) / 20)
    assert fig["shape_rms_diff_mm_core"] == pytest.approx(0.4)
    assert set(dist) == {"core", "skin"}
    assert fig["shape_rms_diff_mm_z"] == pytest.approx(fig["shape_rms_diff_mm"])
    assert fig["shape_rms_diff_mm_plan"] == pytest.approx(0.0, abs=1e-12)
    slid = exp | {"skin_u": np.array([[0.3, 0.0, 0.0], [0.0, 0.0, 0.0]])}
    fig = shape_differences(imp, slid, h)[0]  # a skin node that slid 0.3 mm in plan
    assert fig["shape_rms_diff_mm_plan"] == pytest.approx(0.3 / np.sqrt(6))
    assert fig["shape_rms_diff_mm"] ** 2 == pytest.approx(
        fig["shape_rms_diff_mm_z"] ** 2 + fig["shape_rms_diff_mm_plan"] ** 2)


def test_shape_differences_skip_a_fabric_cell_field():
    """A run with skins stores each skin's cell field next to its nodes
    (``skin_cell_X``, ``skin_cell_x``, ...: no ``_u``). It is not a body: before this
    was caught, ``forming compare hemisphere --set skins=true`` failed on a KeyError
    after both runs had finished."""
    X = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 20.0], [1, 0, 20.0]])
    u = np.zeros((4, 3))
    cells = {"skin_cell_X": X[:1], "skin_cell_x": X[:1], "skin_cell_volume": np.ones(1)}
    imp = {"core_X": X, "core_u": u, "skin_X": X[:2], "skin_u": u[:2]} | cells
    exp = dict(imp)
    fig, dist = shape_differences(imp, exp, reference_thickness(imp))
    assert set(dist) == {"core", "skin"}
    assert fig["shape_max_diff_mm"] == 0.0


def test_shape_differences_need_the_same_mesh():
    X = np.zeros((2, 3))
    with pytest.raises(InputError, match="mesh"):
        shape_differences({"core_X": X, "core_u": X}, {"core_X": X + 1, "core_u": X}, 1.0)


def test_compare_refuses_a_solver_choice(tmp_path):
    with pytest.raises(InputError, match="solver"):
        compare("core_compression", tmp_path, ["solver=explicit"])


def test_compare_names_an_unknown_case(tmp_path):
    with pytest.raises(InputError, match="case"):
        compare("no_such_case", tmp_path, [])


def test_interval_means_filter_the_implicit_force_like_the_explicit_one():
    """With a linear load programme the time mean over an interval is the plain mean in
    the load parameter: for f = s^2 over [a, b] it is (a^2 + ab + b^2) / 3, and the mean
    load parameter is the midpoint. With the smooth step the tool slows down at the end,
    so the last interval's time mean lies nearer its end than its midpoint does."""
    from forming.compare import interval_means
    from forming.solver.options import ExplicitOptions

    s_imp = np.linspace(0.0, 1.0, 2001)
    edges = np.array([0.0, 0.5, 1.0])
    s_mean, f_mean = interval_means(s_imp, s_imp**2, edges,
                                    ExplicitOptions(loading_time=1.0, amplitude="linear"),
                                    samples=2001)
    assert s_mean == pytest.approx([0.0, 0.25, 0.75], abs=1e-9)
    assert f_mean == pytest.approx([0.0, 0.25 / 3, (0.25 + 0.5 + 1.0) / 3], rel=1e-5)
    s_smooth, _f = interval_means(s_imp, s_imp, edges, ExplicitOptions(loading_time=1.0))
    assert s_smooth[-1] > 0.75
