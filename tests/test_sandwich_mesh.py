"""Sandwich blank meshes: bodies, interfaces, named faces, outlines, MPI, bad input."""

from __future__ import annotations

import json
import math

import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from helpers import run_mpi
from mpi4py import MPI

from forming.errors import InputError
from forming.sandwich import Outline, sandwich_blank

H, T = 20.0, 0.4
RECT = Outline.rectangle(100.0, 60.0)
ELLIPSE = Outline(
    tuple((50 * math.cos(a), 30 * math.sin(a)) for a in np.linspace(0, 2 * np.pi, 9)[:-1]),
    kind="spline",
)
L_SHAPE = Outline(((0, 0), (100, 0), (100, 40), (40, 40), (40, 100), (0, 100)))


@pytest.fixture(scope="module")
def rect():
    return sandwich_blank(RECT, core_thickness=H, skin_thickness=T, plies=1, element_size=10.0)


def _volume(md, name: str) -> float:
    msh = md.mesh
    dx = ufl.Measure("dx", domain=msh, subdomain_data=md.cell_tags)
    one = fem.Constant(msh, 1.0)
    local = fem.assemble_scalar(fem.form(one * dx(md.names[name][1])))
    return msh.comm.allreduce(local, op=MPI.SUM)


def _area(md, name: str) -> float:
    msh = md.mesh
    ds = ufl.Measure("ds", domain=msh, subdomain_data=md.facet_tags)
    one = fem.Constant(msh, 1.0)
    return msh.comm.allreduce(fem.assemble_scalar(fem.form(one * ds(md.names[name][1]))))


def _facet_coords(md, name: str) -> np.ndarray:
    """Coordinates of all vertices of the facets of a group, shape (n, 3)."""
    msh = md.mesh
    facets = md.facets(name)
    msh.topology.create_connectivity(2, 3)
    geom = dmesh.entities_to_geometry(msh, 2, facets)
    return msh.geometry.x[geom.reshape(-1)]


def _cell_coords(md, name: str) -> np.ndarray:
    msh = md.mesh
    geom = dmesh.entities_to_geometry(msh, 3, md.cells(name))
    return msh.geometry.x[geom.reshape(-1)]


def _check_all_hex(md):
    assert md.mesh.topology.cell_type == dmesh.CellType.hexahedron
    n = md.mesh.topology.index_map(3).size_local
    tagged = np.concatenate([md.cells(b) for b in ("core", "skin_bottom", "skin_top")
                             if b in md.names])
    assert len(np.unique(tagged[tagged < n])) == n  # every cell in exactly one body


def test_rectangle_bodies_volumes_and_faces(rect):
    md = rect
    _check_all_hex(md)
    assert {md.owned_cell_count(b) for b in ("skin_bottom", "skin_top")} == {10 * 6}
    assert md.owned_cell_count("core") == 10 * 6 * 4
    area = 100.0 * 60.0
    for body, thick in (("core", H), ("skin_bottom", T), ("skin_top", T)):
        assert _volume(md, body) == pytest.approx(area * thick, rel=1e-10)
    z = _facet_coords(md, "top")[:, 2]
    np.testing.assert_allclose(z, 2 * T + H, rtol=1e-12)
    np.testing.assert_allclose(_facet_coords(md, "bottom")[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(_facet_coords(md, "interface_bottom")[:, 2], T, rtol=1e-12)
    np.testing.assert_allclose(_facet_coords(md, "interface_top")[:, 2], T + H, rtol=1e-12)
    assert _area(md, "top") == pytest.approx(area, rel=1e-12)
    assert [b for b, _z0, _z1 in md.layers] == ["skin_bottom", "core", "skin_top"]
    np.testing.assert_allclose([z for _b, *zz in md.layers for z in zz],
                               [0, T, T, T + H, T + H, 2 * T + H], rtol=1e-14)


def test_rectangle_interfaces_are_shared_facets(rect):
    md = rect
    msh = md.mesh
    msh.topology.create_connectivity(2, 3)
    f2c = msh.topology.connectivity(2, 3)
    core = set(md.cells("core").tolist())
    for iface, skin in (("interface_top", "skin_top"), ("interface_bottom", "skin_bottom")):
        facets = md.facets(iface)
        assert len(facets) == 60
        skin_cells = set(md.cells(skin).tolist())
        for f in facets:
            cells = f2c.links(f)
            assert len(cells) == 2
            assert sum(c in core for c in cells) == 1
            assert sum(c in skin_cells for c in cells) == 1


def test_rectangle_lateral_groups_and_unions(rect):
    md = rect
    lateral = md.facets("edge")
    parts = [md.facets(f"{b}_edge") for b in ("skin_bottom", "core", "skin_top")]
    np.testing.assert_array_equal(np.sort(np.concatenate(parts)), lateral)
    assert len(lateral) == 2 * (10 + 6) * (1 + 4 + 1)
    # Each facet has exactly one tag: the groups written to gmsh are disjoint.
    assert len(np.unique(md.facet_tags.indices)) == len(md.facet_tags.indices)
    assert set(md.facet_tag_ids("edge")) == set(md.facet_tags.values) - {1, 2, 3, 4}
    x = _facet_coords(md, "free_edge")
    assert np.all((np.isclose(x[:, 0], 100.0) | np.isclose(x[:, 1], 60.0)).reshape(-1, 4)
                  .all(axis=1))
    with pytest.raises(InputError, match="no 2D physical group 'side'") as err:
        md.facets("side")
    assert err.value.field == "region"


def test_quarter_model_symmetry_planes(rect):
    md = rect
    x = _facet_coords(md, "xmin")
    y = _facet_coords(md, "ymin")
    np.testing.assert_allclose(x[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(y[:, 1], 0.0, atol=1e-12)
    # All layers, from the bottom to the top of the blank.
    assert x[:, 2].min() == 0.0 and x[:, 2].max() == pytest.approx(2 * T + H)
    assert len(md.facets("xmin")) == 6 * 6 and len(md.facets("ymin")) == 10 * 6


def test_two_plies():
    md = sandwich_blank(RECT, core_thickness=H, skin_thickness=T, plies=2, element_size=20.0)
    _check_all_hex(md)
    area = 100.0 * 60.0
    for skin in ("skin_bottom", "skin_top"):
        assert _volume(md, skin) == pytest.approx(2 * T * area, rel=1e-10)
        assert md.owned_cell_count(skin) == 2 * 5 * 3
    levels = np.unique(np.round(_cell_coords(md, "skin_bottom")[:, 2], 9))
    np.testing.assert_allclose(levels, [0.0, T, 2 * T])  # two element layers
    np.testing.assert_allclose(_facet_coords(md, "ply_interface_bottom")[:, 2], T)
    np.testing.assert_allclose(_facet_coords(md, "ply_interface_top")[:, 2], 3 * T + H)
    np.testing.assert_allclose(_facet_coords(md, "top")[:, 2], 4 * T + H, rtol=1e-12)
    assert [b for b, _z0, _z1 in md.layers] == ["skin_bottom"] * 2 + ["core"] + ["skin_top"] * 2


def test_core_alone_and_graded_core():
    md = sandwich_blank(RECT, core_thickness=H, plies=0, skin_thickness=-1.0, element_size=20.0,
                        core_layers=5, grading=2.0)
    _check_all_hex(md)
    assert "skin_top" not in md.names and "interface_top" not in md.names
    assert _volume(md, "core") == pytest.approx(100 * 60 * H, rel=1e-10)
    np.testing.assert_allclose(_facet_coords(md, "top")[:, 2], H)
    levels = np.unique(np.round(_cell_coords(md, "core")[:, 2], 9))
    sizes = np.diff(levels)  # 1 : 2 : 4 : 2 : 1
    np.testing.assert_allclose(sizes / sizes[0], [1, 2, 4, 2, 1], rtol=1e-6)


def _gmsh_spline_area(outline: Outline, n: int = 4000) -> float:
    """Area enclosed by gmsh's closed spline through the outline points (sampled)."""
    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
    gmsh.model.add("spline_area")
    try:
        tags = [gmsh.model.geo.addPoint(x, y, 0.0) for x, y in outline.points]
        curve = gmsh.model.geo.addSpline(tags + [tags[0]])
        gmsh.model.geo.synchronize()
        lo, hi = gmsh.model.getParametrizationBounds(1, curve)
        u = np.linspace(lo[0], hi[0], n, endpoint=False)
        xyz = np.asarray(gmsh.model.getValue(1, curve, u)).reshape(-1, 3)
    finally:
        gmsh.model.remove()
        if not initialised:
            gmsh.finalize()
    x, y = xyz[:, 0], xyz[:, 1]
    return abs(0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))


def test_spline_outline():
    md = sandwich_blank(ELLIPSE, core_thickness=H, skin_thickness=T, element_size=6.0)
    _check_all_hex(md)
    bottom = _area(md, "bottom")
    # The mesh boundary is a polygon inscribed in the spline: about s^3 / (12 R) lost per
    # boundary edge of length s (1.06% for s = 10 mm here, 0.4% for 6 mm).
    assert bottom == pytest.approx(_gmsh_spline_area(ELLIPSE), rel=0.01)
    for body, thick in (("core", H), ("skin_bottom", T), ("skin_top", T)):
        assert _volume(md, body) == pytest.approx(bottom * thick, rel=1e-10)
    assert "xmin" not in md.names and "xmin" not in md.unions  # no straight edge there


def test_non_convex_polygon_outline():
    md = sandwich_blank(L_SHAPE, core_thickness=H, skin_thickness=T, element_size=10.0)
    _check_all_hex(md)
    area = 100 * 40 + 40 * 60
    assert L_SHAPE.polygon_area == pytest.approx(area)
    for body, thick in (("core", H), ("skin_bottom", T), ("skin_top", T)):
        assert _volume(md, body) == pytest.approx(area * thick, rel=1e-10)
    np.testing.assert_allclose(_facet_coords(md, "xmin")[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(_facet_coords(md, "ymin")[:, 1], 0.0, atol=1e-12)


def test_outline_normalised_counter_clockwise():
    cw = Outline(((0, 0), (0, 10), (10, 10), (10, 0), (0, 0)))  # clockwise, explicitly closed
    assert cw.points == ((0, 0), (10, 0), (10, 10), (0, 10))
    assert cw.polygon_area == pytest.approx(100.0)
    assert cw.is_convex_quadrilateral and not L_SHAPE.is_convex_quadrilateral


def test_gmsh_state_restored():
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        sandwich_blank(RECT, element_size=30.0, core_layers=1)
        assert gmsh.isInitialized()
        assert gmsh.option.getNumber("Mesh.Algorithm") == 6
    finally:
        gmsh.finalize()


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"core_thickness": -20.0}, "mesh.core_thickness"),
        ({"skin_thickness": 0.0}, "mesh.skin_thickness"),
        ({"plies": -1}, "mesh.plies"),
        ({"plies": 1.5}, "mesh.plies"),
        ({"element_size": 61.0}, "mesh.element_size"),
        ({"element_size": float("nan")}, "mesh.element_size"),
        ({"core_layers": 0}, "mesh.core_layers"),
        ({"grading": 0.0}, "mesh.grading"),
        ({"outline": L_SHAPE, "structured": True}, "mesh.structured"),
        ({"outline": [(0, 0), (1, 0), (0, 1)]}, "mesh.outline"),
    ],
)
def test_bad_parameters(kwargs, field):
    kwargs = {"outline": RECT, **kwargs}
    with pytest.raises(InputError) as err:
        sandwich_blank(**kwargs)
    assert err.value.field == field


@pytest.mark.parametrize(
    ("points", "kind", "field"),
    [
        (((0, 0), (10, 10), (10, 0), (0, 10)), "polygon", "mesh.outline.points"),  # bow-tie
        (((0, 0), (10, 10), (10, 0), (0, 10)), "spline", "mesh.outline.points"),
        (((0, 0), (10, 0)), "polygon", "mesh.outline.points"),
        (((0, 0), (10, 0), (10, 0), (0, 10)), "polygon", "mesh.outline.points"),
        (((0, 0), (5, 0), (10, 0)), "polygon", "mesh.outline.points"),  # zero area
        (((0, 0), (10, 0), (float("inf"), 5)), "polygon", "mesh.outline.points"),
        (((0, 0), (10, 0), (0, 10)), "bezier", "mesh.outline.kind"),
    ],
)
def test_bad_outlines(points, kind, field):
    with pytest.raises(InputError) as err:
        Outline(points, kind)
    assert err.value.field == field


def test_bad_rectangle():
    with pytest.raises(InputError) as err:
        Outline.rectangle(100.0, -1.0)
    assert err.value.field == "mesh.outline.ly"


def test_not_all_quadrilaterals_is_an_input_error(monkeypatch):
    import forming.sandwich

    monkeypatch.setattr(forming.sandwich, "_GMSH_QUAD", -1)  # no element counts as a quad
    with pytest.raises(InputError, match="triangles") as err:
        sandwich_blank(L_SHAPE, element_size=20.0)
    assert err.value.field == "mesh.outline"
    assert not gmsh.isInitialized()


def test_zero_plies_ignores_skin_data():
    md = sandwich_blank(RECT, plies=0, skin_thickness=-3.0, element_size=60.0, core_layers=1)
    assert md.owned_cell_count("core") == 2


_MPI_SCRIPT = """
import json, sys
import numpy as np
import ufl
from mpi4py import MPI
from forming.sandwich import Outline, sandwich_blank
from dolfinx import fem

md = sandwich_blank(Outline.rectangle(100.0, 60.0), plies=1, element_size=10.0)
msh = md.mesh
imap = msh.topology.index_map(2)
owned = {n: int(np.sum(md.facets(n) < imap.size_local))
         for n in ("interface_top", "interface_bottom", "top", "xmin")}
out = {"cells": msh.topology.index_map(3).size_global,
       "bodies": {b: md.owned_cell_count(b) for b in ("core", "skin_bottom", "skin_top")},
       "facets": {n: msh.comm.allreduce(v) for n, v in owned.items()},
       "ranks": msh.comm.size}
dS = ufl.Measure("dS", domain=msh, subdomain_data=md.facet_tags)
one = fem.Constant(msh, 1.0)
out["interface_area"] = {
    n: msh.comm.allreduce(fem.assemble_scalar(fem.form(one * dS(md.names[n][1]))))
    for n in ("interface_top", "interface_bottom")}
if msh.comm.rank == 0:
    json.dump(out, open(sys.argv[1], "w"))
"""


@pytest.mark.mpi
def test_rectangle_on_two_ranks(tmp_path):
    script = tmp_path / "blank.py"
    script.write_text(_MPI_SCRIPT)
    result = tmp_path / "out.json"
    proc = run_mpi([str(script), str(result)], timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(result.read_text())
    assert out["ranks"] == 2
    assert out["cells"] == 360
    assert out["bodies"] == {"core": 240, "skin_bottom": 60, "skin_top": 60}
    assert out["facets"] == {"interface_top": 60, "interface_bottom": 60, "top": 60, "xmin": 36}
    # Interior-facet integrals over the interfaces across the partition boundary.
    assert out["interface_area"] == pytest.approx({"interface_top": 6000.0,
                                                   "interface_bottom": 6000.0}, rel=1e-12)
