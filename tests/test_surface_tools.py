"""Rigid tools from surface meshes: distances, signs, normals, files and bad input."""

from __future__ import annotations

import meshio
import numpy as np
import pytest
from helpers import block_taylor

from forming.cad import HemisphereToolSet, Tessellation, hemisphere_tool_files
from forming.case import run_case
from forming.contact.shapes import AnnularPlate, HemisphericalPunch, Plane
from forming.contact.surface import SurfaceTool
from forming.errors import InputError
from forming.job import Job
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.model import Model
from forming.run import simulate
from forming.scene import Body, Contact, Displacement, Linear, Scene, Tool, Traction
from forming.solver.options import ExplicitOptions, NewtonOptions
from forming.solver.stepping import StepControl

CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float) * 10.0
CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                   [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


def _stl(path, vertices, faces):
    meshio.write(path, meshio.Mesh(np.asarray(vertices, float), [("triangle", faces)]),
                 binary=True)
    return path


def _box_distance(p, lo=0.0, hi=10.0):
    """Exact signed distance of a box [lo, hi]^3."""
    c, h = (lo + hi) / 2, (hi - lo) / 2
    q = np.abs(p - c) - h
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def test_cube_distance_is_exact_next_to_edges_and_corners(tmp_path):
    """A closed cube of 12 triangles: the signed distance equals the box's exact one to
    1e-12 mm everywhere, at points crowded round its edges and corners on both sides.

    Inside near an edge or a corner the closest point lies on a triangle edge or a
    vertex, where only the pseudo-normal (angle-weighted at vertices) gives the right
    sign: a face-normal test fails there. The normal is the distance's gradient
    (compared by differences of the exact distance, 1e-6).
    """
    tool = SurfaceTool(_stl(tmp_path / "cube.stl", CUBE_V, CUBE_F))
    rng = np.random.default_rng(3)
    corners = CUBE_V[rng.integers(0, 8, 4000)]
    p = np.vstack([corners + rng.normal(scale=0.3, size=(4000, 3)),
                   rng.uniform(-5, 15, (4000, 3))])
    d, n = tool.gap_normal(p)
    exact = _box_distance(p)
    np.testing.assert_allclose(d, exact, atol=1e-12)
    h = 1e-6
    grad = np.stack([(_box_distance(p + h * e) - _box_distance(p - h * e)) / (2 * h)
                     for e in np.eye(3)], axis=1)
    away = np.abs(exact) > 1e-3
    np.testing.assert_allclose(n[away], grad[away], atol=1e-6)


def test_sheet_has_the_tool_behind_its_normals(tmp_path):
    """An open square sheet (normal +z): above it the distance is positive, below it
    negative, also beyond its edges (edge pseudo-normals); ``flip`` turns it round; the
    same sheet declared a closed solid is refused."""
    v = [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]]
    f = np.array([[0, 1, 2], [0, 2, 3]])
    path = _stl(tmp_path / "sheet.stl", v, f)
    p = np.array([[5, 5, 2.0], [5, 5, -2.0], [12, 5, 0.5], [12, 5, -0.5], [5, 5, 0.0]])
    d, n = SurfaceTool(path, sheet=True).gap_normal(p)
    np.testing.assert_allclose(d, [2.0, -2.0, np.hypot(2, 0.5), -np.hypot(2, 0.5), 0.0])
    np.testing.assert_allclose(n[[0, 1, 4]], [[0, 0, 1]] * 3)
    d_flip, _n = SurfaceTool(path, sheet=True, flip=True).gap_normal(p)
    np.testing.assert_allclose(d_flip, -d)
    with pytest.raises(InputError, match=r"sheet.stl: the surface is open \(4 boundary"):
        SurfaceTool(path)


@pytest.fixture(scope="module")
def hemisphere_files(tmp_path_factory):
    """The hemisphere case's tools written as STEP and STL (5 degree tessellation)."""
    folder = tmp_path_factory.mktemp("tools")
    tools = HemisphereToolSet(50.0, 150.0, 72.0, 10.0, 250.0)
    return folder, hemisphere_tool_files(folder, tools, Tessellation(5.0, 25.0))


@pytest.mark.parametrize("suffix", [".stl", ".step"])
def test_tessellated_tools_match_the_analytic_shapes(hemisphere_files, suffix):
    """Punch and die from OpenCASCADE, read as STL or meshed again from STEP: within
    5 mm of the surface the distance differs from the analytic shape's by less than the
    tessellation's chord error (largest edge e on radius R: e^2 / 8R, 0.14 mm for the
    punch's 7.5 mm edges; the die's flat face is exact), and the sign agrees wherever
    the analytic distance exceeds that error. A larger difference means a wrong
    closest point; a sign error, a wrong pseudo-normal or orientation. Within 0.5 mm of
    the surface, the contact's traction direction (corner normals interpolated) is within
    1.5 degrees of the true normal; more means the smoothing is broken."""
    folder, _stl_files = hemisphere_files
    rng = np.random.default_rng(0)
    p = rng.uniform([-200, -200, -40], [200, 200, 40], (40000, 3))
    p = p[np.hypot(p[:, 0], p[:, 1]) < 230]  # the plates are discs of radius 250
    for name, exact in (("punch", HemisphericalPunch((0, 0, 0), 50.0, 150.0)),
                        ("die", AnnularPlate((0, 0, 0), 72.0, 10.0, -1, 50.0))):
        tool = SurfaceTool(folder / f"{name}{suffix}")
        e = tool.surface.edge_lengths
        radius = 50.0 if name == "punch" else 10.0
        curved = e[e < 20.0].max()  # the flat annulus has the long edges
        bound = curved**2 / (8 * radius) + 1e-9
        d, direction = tool.gap_normal(p)
        da, na = exact.gap_normal(p)
        near = np.abs(da) < 5.0
        assert np.abs(d - da)[near].max() <= bound, (name, bound)
        clear = np.abs(da) > bound
        assert np.all(np.sign(d[clear]) == np.sign(da[clear])), name
        # the smoothed traction direction follows the true normal within 1.5 degrees
        # (measured 0.31 punch, 1.01 die), the facets' own normals only within 2.8
        close = np.abs(da) < 0.5
        cos = np.sum(direction[close] * na[close], axis=1)
        assert np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max() < 1.5, name


def test_tracking_walks_with_sliding_points(hemisphere_files):
    """Points sliding 0.3 mm per query over the punch's triangles (edges 3 to 7 mm):
    searched once, then tracked on their facets' one-rings (as within a load step), they
    keep the distance of a full search at every query (1e-12 mm), over 100 mm of travel
    across tens of facets each; a larger difference means a point lost its facet."""
    folder, _stl = hemisphere_files
    tool = SurfaceTool(folder / "punch.stl")
    tracker = tool.tracker()
    rng = np.random.default_rng(5)
    start = rng.uniform([-40, -40, 1], [40, 40, 3], (50, 3))
    for k in range(300):
        p = start + k * np.array([0.3, 0.1, 0.0]) - [40.0, 10.0, 0.0]
        d, _n, c, _m, _k = tracker.query(p)
        d_full = tool.surface.query(p).distance
        np.testing.assert_allclose(d, d_full, atol=1e-12)
        # (the closest point itself need not be unique: inside near the axis, or where
        # gmsh's triangulation of the sphere is not quite convex)
        np.testing.assert_allclose(np.linalg.norm(p - c, axis=1), np.abs(d), atol=1e-12)


def _tetra(path, flip_one=False):
    v = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    if flip_one:
        f[2] = f[2, [0, 2, 1]]
    return _stl(path, v, f)


@pytest.mark.parametrize(("case", "message"), [
    ("missing", r"missing.stl: no such file"),
    ("suffix", r"tool.dxf: unknown surface format '.dxf'"),
    ("garbage", r"garbage.stl: not a readable surface mesh"),
    ("lines", r"lines.vtk: has no triangles"),
    ("nonmanifold", r"nonmanifold.stl: 1 non-manifold edges"),
    ("orientation", r"orientation.stl: inconsistent orientation"),
    ("cad", r"broken.step: gmsh could not read or mesh it"),
])
def test_bad_surface_files_are_refused(tmp_path, case, message):
    """Each fault gets an InputError naming the file and the fault (tool.path)."""
    path = tmp_path / {"missing": "missing.stl", "suffix": "tool.dxf",
                       "garbage": "garbage.stl", "lines": "lines.vtk",
                       "nonmanifold": "nonmanifold.stl", "orientation": "orientation.stl",
                       "cad": "broken.step"}[case]
    if case in ("suffix", "garbage", "cad"):
        path.write_bytes(b"solid nonsense\n\x00\x01 this is not a mesh")
    elif case == "lines":
        meshio.write(path, meshio.Mesh(np.eye(3), [("line", np.array([[0, 1], [1, 2]]))]))
    elif case == "nonmanifold":  # three triangles on the edge 0-1
        _stl(path, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]],
             np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    elif case == "orientation":
        _tetra(path, flip_one=True)
    with pytest.raises(InputError, match=message) as err:
        SurfaceTool(path, sheet=case == "nonmanifold")
    assert err.value.field == "tool.path"


def test_units_far_off_the_blank_are_refused(tmp_path):
    """A closed tetrahedron 10 mm across is accepted for a 300 mm blank, the same file in
    metres (scale 1e-3: 0.01 mm across) is not, with a pointer to ``scale``."""
    path = _tetra(tmp_path / "tetra.stl")
    SurfaceTool(path).check_units(300.0)
    with pytest.raises(InputError, match=r"tetra.stl: the surface is 0.01 mm across"):
        SurfaceTool(path, scale=1e-3).check_units(300.0)


def _table_scene(table_shape, stick: str) -> Scene:
    """A core block 100 x 50 x 20 mm under 2 kPa, its top plate held, dragged over by a
    table moving 5 mm in x (the ASTM D1894 sled of tests/test_contact.py)."""
    return Scene("sled", box((100.0, 50.0, 20.0), (8, 4, 2)), (Body("core", honeycomb_core()),),
                 displacements=(Displacement("core", "top", x=0.0, y=0.0),),
                 tractions=(Traction("core", "top", z=-0.002),),
                 tools=(Tool("table", table_shape, x=Linear(5.0)),),
                 contacts=(Contact("core", "bottom", "table", friction=0.36, stick=stick),))


@pytest.fixture(scope="module")
def table_stl(tmp_path_factory):
    """A 400 mm square sheet at z = 0, normal +z (two triangles)."""
    v = [[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]]
    return _stl(tmp_path_factory.mktemp("table") / "table.stl", v, np.array([[0, 1, 2],
                                                                             [0, 2, 3]]))


def test_sled_on_a_surface_mesh_table_equals_the_analytic_plane(tmp_path, table_stl):
    """The sled dragged by a table given as an STL sheet and as the analytic plane: the
    table is flat, so the tracked gap (closest point and normal, tracking.py) is exact
    and the two histories agree to the Newton tolerance (1e-6 of the 10 N load), the
    sliding force ratio is mu within 1%, and no node penetrates beyond the tolerance.
    A difference means the tracked gap, its normal or the friction along it differ from
    the formula's."""
    runs = {}
    for name, shape in (("plane", Plane((0, 0, 0), (0, 0, 1))),
                        ("stl", SurfaceTool(table_stl, sheet=True))):
        s = simulate(Job(_table_scene(shape, "augmented"), steps=StepControl(initial=0.1,
                                                                             max=0.2),
                         newton=NewtonOptions(line_search="bt")), tmp_path / name, name, {})
        assert s["status"] == "completed"
        runs[name] = (s, np.genfromtxt(tmp_path / name / "history.csv", delimiter=",",
                                       names=True))
    (s_p, h_p), (s_s, h_s) = runs["plane"], runs["stl"]
    for col in ("force_table_x_N", "force_table_z_N", "reaction_top_x_N"):
        np.testing.assert_allclose(h_s[col], h_p[col], rtol=0, atol=1e-5)
    ratio = np.abs(h_s["force_table_x_N"][1:] / h_s["force_table_z_N"][1:])
    np.testing.assert_allclose(ratio, 0.36, rtol=0.01)
    assert "contact_search_s" in s_s["timing"] and "contact_search_s" not in s_p["timing"]
    np.testing.assert_allclose(h_s["max_penetration_mm"], h_p["max_penetration_mm"],
                               atol=1e-6)


@pytest.mark.parametrize("t", [0.01, 0.5])
def test_surface_mesh_contact_jacobian_taylor(table_stl, t):
    """Slopes 1 and 2 of the Taylor remainders of the sled on the STL table (elastic-slip
    stick law; sticking at t = 0.01, sliding at t = 0.5), at a perturbed state with nodes
    open and closed. The closest points are refreshed before every residual; a slope of 1
    would mean the Jacobian and the tracked gap disagree."""
    model = Model(_table_scene(SurfaceTool(table_stl, sheet=True), "elastic_slip"))
    s1, s2 = block_taylor(model, t=t)
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(s2 > 1.9), s2
    gap, _x = model.contacts[0].nodal_gap()
    assert np.count_nonzero(gap < 0.0) >= 5 and np.count_nonzero(gap > 0.0) >= 5, gap


@pytest.mark.parametrize("slope", [0.05, 0.6])
def test_surface_mesh_contact_jacobian_taylor_at_edges(tmp_path, slope):
    """Slopes 1 and 2 of the Taylor remainders of a block pressed 0.5 mm into a V-shaped
    trough (two triangulated planes meeting in a valley line under the block's middle
    row of nodes), with friction (elastic slip).

    Slope 0.05: the valley is smooth (5.7 degrees, below the 30 degree crease angle), so
    the traction direction is the corner normals interpolated and turns over the facets
    next to it. Slope 0.6: the valley is a crease; the middle nodes' closest point is on
    it and the direction is the distance's gradient, which turns round it. Either way
    some penetrating nodes have a turning direction (checked). A second-remainder slope
    of 1 would mean the direction's derivative (``K``, tracking.py) is missing from, or
    wrong in, the Jacobian."""
    v = [[-100, -100, 150 * slope], [50, -100, 0], [50, 150, 0], [-100, 150, 150 * slope],
         [200, -100, 150 * slope], [200, 150, 150 * slope]]
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
    trough = SurfaceTool(_stl(tmp_path / "trough.stl", v, f), sheet=True)
    scene = Scene("trough", box((100.0, 50.0, 20.0), (8, 4, 2)),
                  (Body("core", honeycomb_core()),),
                  displacements=(Displacement("core", "top", x=0.0, y=0.0, z=0.0),),
                  tools=(Tool("trough", trough, z=Linear(0.5)),),
                  contacts=(Contact("core", "bottom", "trough", friction=0.36,
                                    stick="elastic_slip"),))
    model = Model(scene)
    s1, s2 = block_taylor(model, t=1.0)
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(s2 > 1.9), s2
    body = model.body
    x = body.V.tabulate_dof_coordinates()
    sole = np.isclose(x[:, 2], 0.0)
    p = x[sole] + body.u.x.array.reshape(-1, 3)[sole] - [0.0, 0.0, 0.5]
    d, _n, _c, _m, k = trough.surface.query(p)
    assert trough.surface.smooth_edge[0, 1] == (slope < 0.1)  # the valley edge 1-2
    turning = (d < 0.0) & (np.abs(k).max(axis=(1, 2)) > 0.0)
    assert np.count_nonzero(turning) >= 3, (d, np.abs(k).max(axis=(1, 2)))


def test_explicit_sled_on_a_surface_mesh_table_equals_the_analytic_plane(tmp_path, table_stl):
    """The sled of the implicit test run by the explicit solver (nodal contact,
    forming/contact/nodal.py, with the facet tracker searching once per output interval)
    over 0.02 s with mass-proportional damping 1e4 /s, which makes it quasi-static
    (kinetic energy 2e-7 of the internal; undamped, the light sled chatters on its
    penalty springs and its friction never builds, with either table). With the flat STL
    table the histories equal the analytic plane's to 1e-9 N (measured 5e-13) and the
    sliding force ratio is mu within 1%. A difference means the nodal contact takes
    another gap or direction from a surface tool than from a formula."""
    runs = {}
    for name, shape in (("plane", Plane((0, 0, 0), (0, 0, 1))),
                        ("stl", SurfaceTool(table_stl, sheet=True))):
        job = Job(_table_scene(shape, "elastic_slip"), solver="explicit",
                  steps=StepControl(initial=0.1, max=0.1, min=0.1),
                  explicit=ExplicitOptions(loading_time=0.02, damping=1e4))
        s = simulate(job, tmp_path / name, name, {})
        assert s["status"] == "completed", s["reason"]
        assert s["metrics"]["quasi_static"]
        runs[name] = np.genfromtxt(tmp_path / name / "history.csv", delimiter=",", names=True)
    for col in ("force_table_x_N", "force_table_z_N"):
        np.testing.assert_allclose(runs["stl"][col], runs["plane"][col], rtol=0, atol=1e-9)
    h = runs["stl"]
    late = h["t"] > 0.5
    np.testing.assert_allclose(np.abs(h["force_table_x_N"][late] / h["force_table_z_N"][late]),
                               0.36, rtol=0.01)


def test_hemisphere_with_stl_tools_matches_the_analytic_tools(tmp_path):
    """``hemisphere`` with blank holder (8 x 8 x 2 mesh, elastic-slip tool friction) with
    the punch, die and holder given as STL files tessellated at 5 degrees (forming/cad.py)
    against the analytic tools: punch-force RMS difference over the stroke below 1% of
    the RMS force and the final force within 1% (measured 0.34% and 0.08%; the
    12 x 12 x 3 figures and the tessellation study are in docs/validation.md). A larger
    difference means the surface-mesh tools put the contact somewhere else than the
    shapes they were built from."""
    sets = ["blank_holder=true", "cells=8,8,2", "tool_stick=elastic_slip"]
    ref = run_case("hemisphere", tmp_path / "analytic", sets)
    stl = run_case("hemisphere", tmp_path / "stl", [*sets, "tools=stl"])
    assert ref["status"] == stl["status"] == "completed"
    a = np.genfromtxt(tmp_path / "analytic" / "history.csv", delimiter=",", names=True)
    s = np.genfromtxt(tmp_path / "stl" / "history.csv", delimiter=",", names=True)
    f_ref = a["force_punch_z_N"]
    f = np.interp(a["t"], s["t"], s["force_punch_z_N"])
    assert np.sqrt(np.mean((f - f_ref) ** 2)) < 0.01 * np.sqrt(np.mean(f_ref**2))
    assert f[-1] == pytest.approx(f_ref[-1], rel=0.01)
    assert stl["timing"]["contact_search_s"] > 0.0
    assert (tmp_path / "stl" / "tool_punch.pvd").is_file()


def test_generated_tool_folders_appear_complete_or_not_at_all(tmp_path):
    """Generated tool files are written into a scratch folder and renamed into place.

    Two test workers (or two runs) can generate the same hemisphere or demonstrator tools
    at once. A failure means one of them could read a folder the other is still writing
    (half an STL), or a failed writer left a partial folder that later runs take as done.
    """
    from forming.tooling import write_once

    names = ("a.stl", "b.stl")
    target = tmp_path / "tools" / "key"
    calls = []

    def writer(folder):
        calls.append(folder)
        for n in names:
            (folder / n).write_text(n)

    def half_writer(folder):
        (folder / "a.stl").write_text("a")

    with pytest.raises(RuntimeError, match="b.stl"):
        write_once(target, names, half_writer)
    assert not target.exists()

    def racing_writer(folder):  # another process completes the folder meanwhile
        write_once(target, names, writer)
        writer(folder)

    write_once(target, names, racing_writer)
    assert sorted(p.name for p in target.iterdir()) == list(names)
    assert [p.name for p in target.parent.iterdir()] == ["key"]  # no scratch left behind
    assert target.stat().st_mode & 0o777 == 0o755  # readable by others, as any folder
    write_once(target, names, writer)  # complete already: not written again
    assert len(calls) == 2
