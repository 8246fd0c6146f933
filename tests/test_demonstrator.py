"""The demonstrator's geometry: tool solids, component checks, outlines, trim lines, meshes."""

from __future__ import annotations

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from forming.cad import Tessellation, orient_outward
from forming.contact.surface import SurfaceTool
from forming.demonstrator.curves import closed_curve, quarter
from forming.demonstrator.geometry import Component
from forming.demonstrator.setup import Part
from forming.demonstrator.tools import tool_files
from forming.errors import InputError
from forming.layered import sliding_sandwich_mesh
from forming.outline import Outline

CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float) * 10.0
CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                   [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


def _consistent(faces: np.ndarray) -> bool:
    """Every edge is run once in each direction (a closed, consistently oriented surface)."""
    directed = {(int(a), int(b)) for f in faces for a, b in zip(f, np.roll(f, -1), strict=True)}
    return len(directed) == 3 * len(faces) and all((b, a) in directed for a, b in directed)


@pytest.mark.parametrize("seed", range(5))
def test_orienting_a_closed_surface_repairs_any_flipped_triangles(seed):
    """A cube with random triangles flipped comes back closed, consistent and outward.

    A failure means neighbours are compared through edge indices that a flip has
    invalidated: STL files of the demonstrator's tools came out with 304 inconsistent
    edges and were refused.
    """
    rng = np.random.default_rng(seed)
    faces = CUBE_F.copy()
    flip = rng.random(len(faces)) < 0.5
    faces[flip] = faces[flip][:, [0, 2, 1]]
    fixed = orient_outward(CUBE_V, faces)
    assert _consistent(fixed)
    p = CUBE_V[fixed]
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert volume == pytest.approx(1000.0)


@pytest.fixture(scope="module")
def tools(tmp_path_factory):
    """The shipped component's tools on a coarse grid and tessellation (a few seconds)."""
    out = tmp_path_factory.mktemp("demonstrator")
    files = tool_files(out, Component(), Tessellation(angle=5.0, max_size=15.0), grid=10.0)
    return {k: v for k, v in files.items()}


def test_tool_script_writes_watertight_solids_that_follow_the_component(tools):
    """Both tools are closed, manifold, consistently oriented solids (loading them checks
    it), their working faces lie within 0.3 mm of the component's formulas, and the
    closed tools leave the cavity the thickness map asks for (flange, pad, dish).

    The 0.3 mm is the 10 mm interpolation grid and the 5 deg tessellation of this test;
    the shipped defaults (5 mm, 4 deg) give 0.16 mm. A failure means the tools are not the
    part the docs describe, or a tool file would be refused as a solid.
    """
    c = Component()
    lower, upper = SurfaceTool(tools["lower"]), SurfaceTool(tools["upper"])
    assert lower.surface.boundary_edges == 0 and upper.surface.boundary_edges == 0
    for name in ("lower", "upper"):
        assert tools[name].with_suffix(".step").stat().st_size > 1000
    x, y = np.meshgrid(np.linspace(-340, 340, 35), np.linspace(-280, 280, 29))
    for tool, z in ((lower, c.lower_z(x, y)), (upper, c.upper_z(x, y))):
        d, _n = tool.gap_normal(np.column_stack([x.ravel(), y.ravel(), z.ravel()]))
        assert np.abs(d).max() < 0.3
    # along the lower face's normal, the cavity is the core's map plus both skins
    for px, py, core in ((290.0, 0.0, c.flange_core), (c.pad_x, 0.0, c.pad_core),
                         (0.0, 40.0, c.core)):
        base = np.array([px, py, float(c.lower_z(px, py))])
        normal = c.lower_normal(np.array(px), np.array(py))
        mid = base + 0.5 * (core + 2 * c.skin) * normal
        d_up, _ = upper.gap_normal(mid[None])
        d_lo, _ = lower.gap_normal(mid[None])
        assert float(d_up[0] + d_lo[0]) == pytest.approx(core + 2 * c.skin, abs=0.3)


@pytest.mark.parametrize("change, field", [
    ({"rim_radius": 50.0}, "component.rim_radius"),
    ({"pad_x": 150.0}, "component.pad_x"),
    ({"depth": -5.0}, "component.depth"),
    ({"trim": (800.0, 480.0)}, "component"),
    ({"flange_core": 25.0}, "component"),
])
def test_component_refuses_dimensions_that_make_no_part(change, field):
    """A rim tighter than its wall, a pad off the dish bottom, a negative depth, a trim
    line outside the blank or a crushed thickness above the core's are refused by name."""
    with pytest.raises(InputError) as info:
        Component(**change)
    assert info.value.field == field


def _csv(path, points):
    path.write_text("x_mm,y_mm\n" + "\n".join(f"{x},{y}" for x, y in points))
    return str(path)


def test_trim_curves_that_are_open_crossed_or_outside_the_blank_are_refused(tmp_path):
    """Bad trim curves get an InputError naming ``--set trim`` and saying what is wrong."""
    square = [(-200, -200), (200, -200), (200, 200), (-200, 200)]
    arc = np.linspace(0.0, 1.5 * np.pi, 28)  # three quarters of a circle, not closed
    cases = {"open": (list(zip(200 * np.cos(arc), 200 * np.sin(arc), strict=True)), "open"),
             "crossed": ([(-200, -200), (200, 200), (200, -200), (-200, 200)],
                         "intersects itself"),
             "outside": ([(-400, -200), (400, -200), (400, 200), (-400, 200)],
                         "leaves the blank")}
    for name, (points, message) in cases.items():
        with pytest.raises(InputError) as info:
            Part.from_params("lower.stl", "upper.stl", 1.0, None, _csv(tmp_path / f"{name}.csv",
                                                                       points), 20.8)
        assert info.value.field == "--set trim"
        assert message in str(info.value), name
    part = Part.from_params("lower.stl", "upper.stl", 1.0, None,
                            _csv(tmp_path / "ok.csv", square), 20.8)
    assert part.trim.shape == (4, 2)


def _rounded_rectangle_area(a: float, b: float, r: float) -> float:
    return 4 * a * b - (4 - np.pi) * r * r


def test_dxf_outlines_read_as_drawn_and_bad_ones_are_refused(tmp_path):
    """A blank outline in DXF, as CAD draws it: a rounded rectangle (600 x 480, R60) as one
    closed LWPOLYLINE with arc bulges, the same as LINEs and ARCs meeting end to end (in
    cm, converted by $INSUNITS), and the optimiser's own output read back. Areas within
    1e-4 of the analytic (the arcs flattened to 0.01 mm). Files with no closed outline,
    two outlines, an open chain or garbage get an InputError naming ``--set blank``. A
    failure means a user's DXF blank is misread."""
    import ezdxf

    from forming.demonstrator.curves import read_points
    from forming.demonstrator.dxf import write_outline

    a, b, r = 300.0, 240.0, 60.0
    area = _rounded_rectangle_area(a, b, r)
    bulge = np.tan(np.pi / 8)  # a quarter circle
    doc = ezdxf.new("R2010", units=4)
    corners = [(a - r, -b, bulge), (a, -b + r, 0), (a, b - r, bulge), (a - r, b, 0),
               (-a + r, b, bulge), (-a, b - r, 0), (-a, -b + r, bulge), (-a + r, -b, 0)]
    doc.modelspace().add_lwpolyline([(x, y, 0, 0, g) for x, y, g in corners],
                                    format="xyseb", close=True)
    doc.modelspace().add_text("blank, rev. A")  # not a curve: ignored
    doc.saveas(tmp_path / "poly.dxf")
    pts = closed_curve(read_points(tmp_path / "poly.dxf", "--set blank"), "--set blank")
    assert Outline(tuple(map(tuple, pts))).polygon_area == pytest.approx(area, rel=1e-4)

    doc = ezdxf.new("R2010", units=5)  # centimetres
    msp = doc.modelspace()
    c = [(a - r, b - r), (-a + r, b - r), (-a + r, -b + r), (a - r, -b + r)]
    for k, (cx, cy) in enumerate(c):  # arcs at the corners, lines between (shuffled ends)
        msp.add_arc((cx / 10, cy / 10), r / 10, 90 * k, 90 * (k + 1))
    msp.add_line((a / 10, (-b + r) / 10), (a / 10, (b - r) / 10))
    msp.add_line((-a / 10, (b - r) / 10), (-a / 10, (-b + r) / 10))
    msp.add_line(((a - r) / 10, b / 10), ((-a + r) / 10, b / 10))
    msp.add_line(((a - r) / 10, -b / 10), ((-a + r) / 10, -b / 10))  # drawn backwards
    doc.saveas(tmp_path / "chain.dxf")
    pts = closed_curve(read_points(tmp_path / "chain.dxf", "--set blank"), "--set blank")
    assert Outline(tuple(map(tuple, pts))).polygon_area == pytest.approx(area, rel=1e-4)

    octagon = np.column_stack([300 * np.cos(np.arange(8) * np.pi / 4),
                               200 * np.sin(np.arange(8) * np.pi / 4)])
    back = read_points(write_outline(tmp_path / "out.dxf", octagon), "--set blank")
    np.testing.assert_allclose(back, octagon, atol=1e-9)

    doc = ezdxf.new("R2010", units=4)
    doc.modelspace().add_line((0, 0), (100, 0))
    doc.modelspace().add_line((100, 0), (100, 100))
    doc.saveas(tmp_path / "open.dxf")
    doc = ezdxf.new("R2010", units=4)
    doc.modelspace().add_circle((0, 0), 100)
    doc.modelspace().add_circle((0, 0), 200)
    doc.saveas(tmp_path / "two.dxf")
    doc = ezdxf.new("R2010", units=4)
    doc.modelspace().add_text("nothing")
    doc.saveas(tmp_path / "empty.dxf")
    (tmp_path / "junk.dxf").write_text("this is not a drawing\n")
    for name, message in (("open", "the outline is open"), ("two", "2 closed outlines"),
                          ("empty", "no closed outline"), ("junk", "not a readable DXF"),
                          ("missing", "no such file")):
        with pytest.raises(InputError) as info:
            read_points(tmp_path / f"{name}.dxf", "--set blank")
        assert info.value.field == "--set blank"
        assert message in str(info.value), name


def test_a_symmetric_outline_is_cut_to_its_quarter_and_an_asymmetric_one_refused():
    """The quarter of a symmetric octagon has its area / 4 with edges on both axes; an
    outline shifted off x = 0 is refused (the case models a quarter)."""
    a = np.linspace(0, 2 * np.pi, 9)[:-1] + np.pi / 8
    octagon = np.column_stack([300 * np.cos(a), 200 * np.sin(a)])
    q = quarter(octagon)
    full = Outline(tuple(map(tuple, octagon))).polygon_area
    assert q.polygon_area == pytest.approx(full / 4, rel=1e-12)
    assert min(x for x, _ in q.points) == 0.0 and min(y for _, y in q.points) == 0.0
    with pytest.raises(InputError, match="not symmetric about x = 0"):
        quarter(octagon + np.array([10.0, 0.0]))
    with pytest.raises(InputError, match="intersects itself"):
        closed_curve(octagon[[0, 4, 1, 5, 2, 6, 3, 7]], "--set blank")


@pytest.mark.parametrize("refinement", [1, 2])
def test_sliding_sandwich_of_any_outline_has_its_volumes_and_faces(refinement):
    """Each body of a cut-corner outline has the outline's area times its thickness, and
    its named faces the areas of the outline, its symmetry edges and its free edge, on
    matching (1) and finer (2) skin meshes. A failure means a face group is missing faces
    or the bodies overlap."""
    o = Outline(((0, 0), (360, 0), (360, 200), (300, 295), (0, 295)))
    md = sliding_sandwich_mesh(o, 20.0, 0.4, 1, element_size=30.0, core_layers=2,
                               refinement=refinement)
    m = md.mesh
    dx = ufl.Measure("dx", domain=m, subdomain_data=md.cell_tags)
    ds = ufl.Measure("ds", domain=m, subdomain_data=md.facet_tags)

    def integral(measure, name):
        form = fem.form(fem.Constant(m, 1.0) * measure(md.names[name][1]))
        return m.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    area = 360 * 295 - 60 * 95 / 2
    free = 200 + np.hypot(60, 95) + 300
    for body, t in (("core", 20.0), ("skin_bottom", 0.4), ("skin_top", 0.4)):
        assert integral(dx, body) == pytest.approx(area * t, rel=1e-12)
        for face, expected in (("top", area), ("bottom", area), ("xmin", 295 * t),
                               ("ymin", 360 * t), ("edge", free * t)):
            assert integral(ds, f"{body}_{face}") == pytest.approx(expected, rel=1e-12)


def _cylinder_map(folder, radius: float = 400.0):
    """A forming map known in closed form: the flat blank wrapped round a cylinder along x
    (plan x = R sin(X / R), y = Y), written as a run's ``forming_map.npz``."""
    from forming.demonstrator.report import FORMING_MAP

    xs, ys = np.linspace(0.0, 380.0, 39), np.linspace(0.0, 300.0, 31)
    X, Y = np.meshgrid(xs, ys)
    corners = np.stack([np.column_stack([X[:-1, :-1].ravel(), Y[:-1, :-1].ravel()]),
                        np.column_stack([X[:-1, 1:].ravel(), Y[:-1, 1:].ravel()]),
                        np.column_stack([X[1:, 1:].ravel(), Y[1:, 1:].ravel()]),
                        np.column_stack([X[1:, :-1].ravel(), Y[1:, :-1].ravel()])], axis=1)
    ref = np.concatenate([corners, np.zeros(corners.shape[:2] + (1,))], axis=2)
    cur = ref.copy()
    cur[..., 0] = radius * np.sin(ref[..., 0] / radius)
    cur[..., 2] = radius * (1 - np.cos(ref[..., 0] / radius))
    edge_y = np.linspace(0.0, 240.0, 25)  # the blank's edge x = 380, beside the trim line
    edge = np.repeat(np.column_stack([np.full(25, radius * np.sin(380.0 / radius)), edge_y,
                                      np.zeros(25)])[:, None], 4, axis=1)
    trim = np.array([(-300.0, -240.0), (300.0, -240.0), (300.0, 240.0), (-300.0, 240.0)])
    np.savez(folder / FORMING_MAP, reference=ref, current=cur, edge_reference=edge,
             edge_current=edge, trim=trim, blank=np.array([(-380.0, -300.0), (380, -300),
                                                           (380, 300), (-380, 300)]))
    return radius


def test_trim_line_maps_back_to_the_developed_outline_of_a_cylinder(tmp_path):
    """Wrapped round a cylinder of radius R, a part trimmed at |x| = 300 needs a blank
    of half length R asin(300 / R) (the developed length), |y| = 240 unchanged: the
    back-mapped outline has both within 1% (measured: 0.23% and 0.40%, where the
    outline's spline overshoots at the trim's square corners). A failure means the
    inverse forming map (barycentric in the formed triangles) or the outline's spline and
    symmetrisation are wrong."""
    from forming.demonstrator.optimise import FormingMap, next_blank

    radius = _cylinder_map(tmp_path)
    fmap = FormingMap.read(tmp_path)
    outline = next_blank(fmap)
    half_x = radius * np.arcsin(300.0 / radius)
    assert np.abs(outline[:, 0]).max() == pytest.approx(half_x, rel=0.01)
    assert np.abs(outline[:, 1]).max() == pytest.approx(240.0, rel=0.01)
    # every trim point comes back to its developed position
    back = fmap.back(np.array([[300.0, 0.0], [150.0, 240.0], [-300.0, -120.0]]))
    expected = np.array([[half_x, 0.0], [radius * np.arcsin(150.0 / radius), 240.0],
                         [-half_x, -120.0]])
    assert np.allclose(back, expected, atol=0.01 * half_x)
    # the formed edge (x = R sin(380 / R)) is this far outside the trim line
    dev = fmap.deviation()
    assert dev.max() == pytest.approx(radius * np.sin(380.0 / radius) - 300.0, rel=1e-6)


def test_the_forming_map_is_the_core_mid_surface_of_a_sheared_edge():
    """Top and bottom faces of an extruded core whose top slid 2 mm further out than its
    bottom (skin-core slip shears the blank's edge): ``Faces.midway`` pairs each top
    corner with the bottom corner of the same node column (listed in another order) and
    returns the mid-surface, 1 mm out. A failure means the blank development maps the
    trim line through one face of the core, leaving the other a full tilt off."""
    from forming.demonstrator.final import Faces

    quad = np.array([[0.0, 0.0], [30.0, 0.0], [30.0, 30.0], [0.0, 30.0]])
    ref_top = np.column_stack([quad, np.full(4, 20.0)])[None]
    ref_bottom = np.column_stack([quad[::-1], np.zeros(4)])[None]  # reversed: looks down
    cur_top = ref_top + [2.0, 0.0, -13.0]  # crushed to 7 mm, slid 2 mm in x
    one = np.ones(1)
    top = Faces(cur_top, ref_top, np.array([[0, 0, 1.0]]), one, one.astype(int), {})
    bottom = Faces(ref_bottom.copy(), ref_bottom, np.array([[0, 0, -1.0]]), one,
                   one.astype(int), {})
    mid = top.midway(bottom)
    np.testing.assert_allclose(mid[0], ref_top[0] + [1.0, 0.0, -16.5], atol=1e-12)


def test_one_report_measures_each_run_on_its_own_fields(monkeypatch):
    """``forming compare`` builds one job, so one report, for its implicit and its
    explicit run. Its measured faces (conformity gaps, core thickness, draw-in, the maps
    and the forming map) are gathered once per run and load, and the metrics and
    pictures hooks of one run share them. A failure means the explicit run is reported
    with the implicit run's fields: on the 60 mm demonstrator the two runs' gaps,
    thicknesses and draw-ins were equal to 16 digits, and their maps the same."""
    from forming.demonstrator.report import Report

    gathered = []

    def gather(self, model, t):
        gathered.append((model, t))
        return {"fields": (model.name, t)}

    monkeypatch.setattr(Report, "_gather", gather)
    monkeypatch.setattr(Report, "_analyse", lambda self, g: {"metrics": g["fields"]})

    class Run:
        def __init__(self, name):
            self.name = name

    report = Report(None, None, 50.0, 0.5, 20.0)
    implicit, explicit = Run("implicit"), Run("explicit")
    assert report._measure(implicit, 1.0)["metrics"] == ("implicit", 1.0)
    assert report._measure(implicit, 1.0)["metrics"] == ("implicit", 1.0)  # pictures
    assert report._measure(explicit, 1.0)["metrics"] == ("explicit", 1.0)
    assert report._measure(explicit, 0.5)["metrics"] == ("explicit", 0.5)
    assert len(gathered) == 3


@pytest.mark.slow
def test_demonstrator_closes_the_tools_and_reaches_the_cavity(tmp_path, pictures):
    """The shipped part on the 60 mm mesh (the main job's), serial: the tools close, the
    skins stay out of them (penetration within the contact tolerance), the flange's core
    is crushed to the cavity's 7 mm within 10%, no skin shears past the wrinkling angles
    (the part's shear stays within +-25 deg on this mesh), and the draw-in is a few
    mm. A failure means the matched tools, the sliding skins or the measurements of
    forming/demonstrator/report.py have broken. About 3 minutes: ``scripts/dev.sh
    validate``."""
    from forming.case import run_case

    s = run_case("demonstrator", tmp_path, ["element_size=60"])
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    assert m["closed_fraction"] == 1.0
    assert m["max_penetration_mm"] <= 1.01 * m["penetration_tolerance_mm"]
    assert m["core_thickness_min_mm"] == pytest.approx(Component().flange_core, rel=0.10)
    assert -25.0 < m["shear_min_deg"] < 0.0 < m["shear_max_deg"] < 25.0
    assert 0.0 < m["edge_draw_in_max_mm"] < 20.0
    for png in ("shear_angle_map", "conformity_map", "core_thickness_map", "draw_in_map",
                "fibre_compression_map", "section_y0", "closing_force"):
        assert (tmp_path / f"{png}.png").is_file(), png
    assert (tmp_path / "forming_map.npz").is_file()


def test_the_blank_is_held_along_the_closing_direction_from_the_first_step(tmp_path):
    """The default start, on the 60 mm mesh: after the first load step a rigid lift of
    the whole blank (every body's nodes moved 1 mm along z) meets the tools' contact
    stiffness: e.K.e above 100 N/mm (30,040 N/mm measured, 3,004 with
    ``tool_penalty_scale=1``; 4e-11 N/mm, none, with the upper tool starting 1 mm above
    the blank). A failure means the blank floats again before
    the upper tool touches it: nothing then sets its height but the round-off of the
    linear solves, which differs between partitions and between runs on several ranks,
    and serial and parallel runs part from the first steps (docs/theory.md, section 16).

    Before that, the tools' placement: the nearest node of the blank's top face is on the
    upper tool, the nearest of its bottom face on the lower tool (1e-9 mm), as the
    contacts see them. Placed by their surfaces' extreme vertices, the upper tool started
    0.0166 mm above the nearest node (a facet's sag between nodes) and the lower 0.0027
    mm below the blank, which floated in the first step with the weaker skin springs."""
    from helpers import block_vector, free_mask

    from forming.case import load_case
    from forming.simulation import Simulation

    case = load_case("demonstrator")
    job = case.build(case.Params(element_size=60.0))
    assert job.cautions == ()  # (the floating start's caution: the test below)
    x = job.scene.mesh.mesh.geometry.x
    lower, upper = (t.shape for t in job.scene.tools)
    assert abs(upper.gap_normal(x[np.isclose(x[:, 2], x[:, 2].max())])[0].min()) < 1e-9
    assert abs(lower.gap_normal(x[np.isclose(x[:, 2], x[:, 2].min())])[0].min()) < 1e-9
    sim = Simulation(job, tmp_path, case="demonstrator")
    # the first attempt, at the initial step size, may be cut back
    assert any(sim.step().converged for _ in range(8)), "no first step in 8 attempts"
    model, A = sim.model, sim.solver.problem.A
    free = free_mask(model, A.getLocalSize()[1])
    lift = block_vector(model, {n: lambda X: np.tile([0.0, 0.0, 1.0], (len(X), 1))
                                for n in model.names}) * free
    x, y = A.createVecs()
    x.array[:] = lift
    A.mult(x, y)
    assert float(lift @ (y.array * free)) > 100.0


def test_a_floating_blank_is_flagged_in_the_run_s_warnings():
    """With ``clearance > 0`` the blank starts below the open upper tool, held by nothing
    along z: its height, and from there the step path, follow round-off (the test above).
    The job carries a caution that the run writes to summary.json's warnings; the
    default start carries none (asserted by the test above, which builds it). A failure
    means a user can float the blank and get rank-dependent answers without being told."""
    from forming.case import load_case

    case = load_case("demonstrator")
    (caution,) = case.build(case.Params(element_size=60.0, clearance=1.0)).cautions
    assert "clearance = 1 mm" in caution and "round-off" in caution
