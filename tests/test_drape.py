"""Kinematic draping (forming/drape.py): exact on a cylinder, against KinDrape on a
hemisphere, converging to the continuous Chebyshev net, and its command and input checks.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import meshio
import numpy as np
import pytest
from helpers import run_python

from forming.contact.shapes import HemisphericalPunch, Roller
from forming.drape import DrapeSettings, ShapeSurface, chebyshev_sphere_shear, drape
from forming.drape_case import case_drape
from forming.errors import EXIT_CODES, InputError

DATA = Path(__file__).parent / "data"


def unit_hemisphere(cut_deg: float | None = None) -> ShapeSurface:
    """The unit hemisphere, centre at the origin, pole at z = 1, cut at a polar angle."""
    bounds = None if cut_deg is None else (
        (-2.0, -2.0, math.cos(math.radians(cut_deg))), (2.0, 2.0, 2.0))
    return ShapeSurface(HemisphericalPunch((0.0, 0.0, 1.0), 1.0, length=1.0, direction=1),
                        bounds=bounds)


def pole_centred(d: float, nodes: int) -> DrapeSettings:
    """KinDrape's start: the origin node at (-d/2, -d/2), the pole at the origin cell's
    centre, families along x and y."""
    o = nodes // 2 - 1
    return DrapeSettings(start=(-d / 2, -d / 2, math.sqrt(1 - d * d / 2)), spacing=d,
                         nodes=(nodes, nodes), origin=(o, o), angle=0.0)


@pytest.mark.parametrize("angle", [0.0, 90.0])
def test_cylinder_net_is_the_rolled_up_flat_grid(angle):
    """On a cylinder (R = 50 mm, axis along y, moved off the origin) a net with one family
    around and one along the axis is the flat grid rolled up: the edges along the axis are
    straight, those around it are chords of length d, so node (i, j) sits at the angle
    k * 2 asin(d / 2R) and at k' d along the axis, with zero shear. 41 x 21 nodes at
    d = 5 mm wrap 2 rad either side of the top, past the vertical.

    Tolerances: positions within 1e-9 R, shear within 1e-9 deg (round-off: the
    construction is exact here). A failure means the arms' zero-shear Newton, the
    sphere-sphere-surface fill or the first edge's plan-view angle are wrong."""
    R, d, centre = 50.0, 5.0, np.array([10.0, 3.0, -2.0])
    surface = ShapeSurface(Roller((0.0, 0.0, 0.0), R), shift=tuple(centre))
    nodes = (41, 21) if angle == 0.0 else (21, 41)
    st = DrapeSettings(start=tuple(centre + [0.0, 0.0, R]), spacing=d, nodes=nodes,
                       angle=angle)
    r = drape(surface, st)
    assert r.placed == nodes[0] * nodes[1] and not r.failures
    i, j = np.meshgrid(np.arange(nodes[0]) - st.origin[0], np.arange(nodes[1]) - st.origin[1],
                       indexing="ij")
    around, along = (i, j) if angle == 0.0 else (j, i)
    sense = 1.0 if angle == 0.0 else -1.0  # the family around runs along +x, or along -x
    theta = around * 2 * math.asin(d / (2 * R))
    exact = centre + np.stack([sense * R * np.sin(theta), along * d, R * np.cos(theta)], -1)
    assert np.abs(r.nodes - exact).max() < 1e-9 * R
    for shear in (r.corner_shear, r.cell_shear, r.node_shear):
        assert np.abs(shear).max() < 1e-9


def test_hemisphere_matches_kindrape():
    """KinDrape's own test (tests/data/kindrape_hemisphere.md): a unit hemisphere cut at
    81 deg polar angle, d = 0.075, 24 x 24 nodes, origin node (11, 11) at (-d/2, -d/2),
    families along x and y. Compared node by node with KinDrape.py (SLSQP generator cells)
    and KinDrape_eff_NR.py (Newton generator cells), run outside this repository.

    Tolerances (the issue's): positions within 1e-3 of the radius, cell shear within
    0.5 deg. Measured: 1.1e-4 and 0.035 deg. KinDrape's mould is an interpolant of the
    sphere whose nodes lie up to 1.06e-4 off it; with its nodes moved radially onto the
    exact sphere the position difference falls to 4e-5 (checked below at 1e-4). A failure
    means the construction (arms, fill, or the shear measure) departs from KinDrape's."""
    ref = np.load(DATA / "kindrape_hemisphere.npz")
    d = float(ref["spacing"])
    r = drape(unit_hemisphere(81.0), pole_centred(d, 24))
    assert r.placed == 24 * 24
    for key in ("nodes", "nodes_eff_nr"):
        assert np.linalg.norm(r.nodes - ref[key], axis=-1).max() < 1e-3
        on_sphere = ref[key] / np.linalg.norm(ref[key], axis=-1, keepdims=True)
        assert np.linalg.norm(r.nodes - on_sphere, axis=-1).max() < 1e-4
    # KinDrape.py: |90 - corner angle| at every corner and their mean per cell
    assert np.abs(np.abs(r.corner_shear) - ref["corner_shear_abs_deg"]).max() < 0.5
    assert np.abs(np.abs(r.corner_shear).mean(axis=2)
                  - ref["cell_shear_mean_abs_deg"]).max() < 0.5
    # KinDrape_eff_NR.py: |mean signed corner shear| per cell
    assert np.abs(np.abs(r.cell_shear) - ref["cell_shear_eff_nr_deg"]).max() < 0.5
    # both shear signs appear, antisymmetric about the diagonals (families along x and y)
    assert r.shear_range()[0] == pytest.approx(-r.shear_range()[1], abs=1e-6)
    assert r.shear_range()[1] == pytest.approx(38.0, abs=0.1)


def test_hemisphere_shear_converges_to_the_chebyshev_net():
    """As d halves (0.1, 0.05, 0.025) the shear of the cell centred at fabric coordinates
    (u, v) = (0.8, 0.4) from the pole (a fixed point of the hemisphere, near (0.705,
    0.383, 0.597)) converges at second order to the continuous Chebyshev net with
    geodesic generators, omega_uv = -sin(omega) (forming.drape.chebyshev_sphere_shear:
    18.2311 deg). Measured errors 0.0061, 0.0015, 0.0004 deg.

    Tolerances: each halving divides the error by 3 to 5; at d = 0.025 it is below
    2e-3 deg. A failure means the net does not converge to the surface's net (a wrong
    generator criterion or a first-order error, such as an off-centre origin cell)."""
    u, v = 0.8, 0.4
    limit = chebyshev_sphere_shear(u, v)
    errors, points = [], []
    for d in (0.1, 0.05, 0.025):
        k, m = round(u / d), round(v / d)
        st = pole_centred(d, 2 * k + 4)
        r = drape(unit_hemisphere(), st)
        i, j = st.origin[0] + k, st.origin[1] + m
        errors.append(abs(r.cell_shear[i, j] - limit))
        points.append(r.nodes[i:i + 2, j:j + 2].reshape(-1, 3).mean(axis=0))
    assert all(3.0 < errors[n] / errors[n + 1] < 5.0 for n in (0, 1)), errors
    assert errors[-1] < 2e-3
    assert np.linalg.norm(points[-1] - points[-2]) < 1e-3  # the same point of the surface


def test_a_surface_that_ends_stops_the_net():
    """The hemisphere cut at 60 deg: nodes past the cut (and those built from them) are
    NaN, the reason is recorded, and every placed node is where the uncut drape puts it
    (to 1e-12): the net stops, it does not bend at the edge. A failure means nodes off the
    surface's extent are kept or the cut changes the rest of the net."""
    st = pole_centred(0.075, 24)
    whole, cut = drape(unit_hemisphere(), st), drape(unit_hemisphere(60.0), st)
    placed = np.isfinite(cut.nodes[..., 0])
    assert 0 < placed.sum() < whole.placed == 24 * 24
    assert cut.failures.get("off the surface's extent", 0) > 0
    assert np.all(cut.nodes[placed][:, 2] >= 0.5 - 1e-12)
    assert not placed[whole.nodes[..., 2] < 0.5].any()
    assert np.abs(cut.nodes[placed] - whole.nodes[placed]).max() < 1e-12
    assert np.isnan(cut.cell_shear[~np.isfinite(cut.cell_shear)]).all()


def test_sign_convention_and_clearance():
    """Families at -45 / +45 deg (the skins' NCF, angle = -45) on the unit hemisphere: the
    shear is positive (families closing, the fabric model's positive branch) along x, the
    families' bisector, and negative along y. A clearance c on a sphere of radius 1 gives
    the drape of the sphere of radius 1 + c (to 1e-12). A failure means the sign
    convention of docs/theory.md section 14 or the clearance is broken."""
    st = DrapeSettings(start=(0.0, 0.0, 1.0), spacing=0.1, nodes=(20, 20), angle=-45.0)
    r = drape(unit_hemisphere(), st)
    centres = np.nanmean(np.stack([r.nodes[:-1, :-1], r.nodes[1:, 1:]]), axis=0)
    along_x = (np.abs(centres[..., 1]) < 0.1) & (np.abs(centres[..., 0]) > 0.5)
    along_y = (np.abs(centres[..., 0]) < 0.1) & (np.abs(centres[..., 1]) > 0.5)
    assert along_x.sum() > 4 and along_y.sum() > 4
    assert np.all(r.cell_shear[along_x] > 5) and np.all(r.cell_shear[along_y] < -5)
    big = ShapeSurface(HemisphericalPunch((0.0, 0.0, 1.2), 1.2, length=1.0, direction=1))
    st2 = DrapeSettings(start=(0.0, 0.0, 1.2), spacing=0.1, nodes=(12, 12), angle=-45.0)
    a = drape(big, st2)
    b = drape(unit_hemisphere(), DrapeSettings(start=(0.0, 0.0, 1.2), spacing=0.1,
                                               nodes=(12, 12), angle=-45.0, clearance=0.2))
    assert np.abs(a.nodes - b.nodes).max() < 1e-12


def test_bad_input_names_the_field():
    """Non-positive or non-finite spacing, too few nodes, an origin off the grid, a start
    off the surface and an unknown tool are refused with an InputError naming the field.
    A failure means a bad input is accepted or the message does not say which one."""
    ok = {"start": (0.0, 0.0, 1.0), "spacing": 0.1}
    for bad, field in (({"spacing": 0.0}, "spacing"), ({"spacing": -1.0}, "spacing"),
                       ({"spacing": math.nan}, "spacing"), ({"nodes": (1, 5)}, "nodes"),
                       ({"origin": (23, 0)}, "origin"), ({"start": (0.0, math.inf, 1.0)},
                                                          "start"),
                       ({"side": 0}, "side"), ({"clearance": -0.1}, "clearance")):
        with pytest.raises(InputError) as exc:
            DrapeSettings(**(ok | bad))
        assert exc.value.field == field and str(exc.value).startswith(field)
    with pytest.raises(InputError) as exc:  # 1 above the pole: more than d/2 off the surface
        drape(unit_hemisphere(), DrapeSettings(start=(0.0, 0.0, 2.0), spacing=0.1))
    assert exc.value.field == "start" and "from the surface" in str(exc.value)
    with pytest.raises(InputError) as exc:
        case_drape("hemisphere", [], tool="anvil")
    assert exc.value.field == "--tool" and "'punch'" in str(exc.value)
    with pytest.raises(InputError) as exc:
        case_drape("hemisphere", [], spacing=-2.0)
    assert exc.value.field == "--spacing"


def test_drape_of_the_sandwich_starts_at_the_punch_tip():
    """With skins the blank's faces are named per body (core_xmin, skin_top_xmin, ...): the
    quarter model is still mirrored, so the net starts at the punch's tip, not at the
    quarter's centre (where it ran off the punch: 'no surface point ... from the start')."""
    result, info = case_drape("hemisphere", ["skins=true", "cells=8,8,2"])
    assert info["blank_box_mm"][0][:2] == pytest.approx([-150.0, -150.0])
    assert info["net_centre_mm"][:2] == pytest.approx([0.0, 0.0], abs=1e-9)
    lo, hi = result.shear_range()
    assert result.placed > 30 and hi > 20 and lo == pytest.approx(-hi, abs=1e-6)


def test_forming_drape_hemisphere_writes_map_fields_and_summary(tmp_path):
    """forming drape hemisphere: exit 0, drape.json (settings, shear range, wrinkling area
    fraction, node count, its wall time: recorded, not timed here; its speed is
    benchmarks/validate_drape.py's), shear_angle.png, drape.vtu (quads with
    the cell shear) and drape.npz (the net's arrays) in --out; the net is centred on the
    punch's tip (the origin cell's centre) and covers the punch up to its equator (the
    blank cannot reach the shank), with shear of both signs, antisymmetric to 1e-6 deg.
    A rerun replaces it; a folder holding other files, and an unknown tool, exit 2 naming
    the field. A failure means the command, its defaults or its output contract broke."""
    out = tmp_path / "drape"
    for _ in range(2):  # the second run clears the first
        proc = run_python(["-m", "forming.cli", "drape", "hemisphere", "--out", str(out)],
                          timeout=120)
        assert proc.returncode == 0, proc.stderr[-2000:]
    rec = json.loads((out / "drape.json").read_text())
    assert rec["tool"] == "punch" and rec["settings"]["angle"] == -45.0
    assert rec["net_centre_mm"] == pytest.approx([0.0, 0.0, -30.0], abs=1e-9)  # the tip
    start = np.array(rec["settings"]["start"])
    assert np.linalg.norm(start[:2]) == pytest.approx(rec["settings"]["spacing"] / 2**0.5, rel=0.01)
    assert rec["wall_s"] > 0 and 0 < rec["nodes_placed"] < rec["nodes_total"]
    assert rec["shear_max_deg"] > 30
    assert rec["shear_min_deg"] == pytest.approx(-rec["shear_max_deg"], abs=1e-6)
    assert 0 <= rec["area_fraction_beyond_limits"] < 0.1
    assert rec["wrinkling_limits_deg"] == [42.0, -50.0]
    assert (out / "shear_angle.png").stat().st_size > 20_000
    with np.load(out / "drape.npz") as z:
        assert z["node_shear"].shape == tuple(rec["settings"]["nodes"])
        o = tuple(int(v) for v in z["origin"])
        assert z["nodes"][o] == pytest.approx(start)
    mesh = meshio.read(out / "drape.vtu")
    shear = mesh.cell_data["shear_angle_deg"][0]
    assert len(shear) > 100 and np.isfinite(shear).all()
    assert np.all(mesh.points[:, 2] <= 20.0 + 1e-6)  # the punch ends at the blank's top
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("keep")
    for args, field in ((["--out", str(tmp_path / "other")], "--out"),
                        (["--tool", "anvil", "--out", str(tmp_path / "x")], "--tool")):
        proc = run_python(["-m", "forming.cli", "drape", "hemisphere", *args], timeout=120)
        assert proc.returncode == EXIT_CODES["input"] and field in proc.stderr
