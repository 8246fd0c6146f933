"""Meso-scale honeycomb pulled in its plane: the lattice's in-plane moduli (issue 20, item 5).

``meso_compression --set load=tension_x|tension_y`` pulls a patch of cell walls by its
cut faces; :mod:`forming.meso.inplane` says which measures are the infinite lattice's.
"""

from __future__ import annotations

import json
import math

import pytest
import ufl
from dolfinx import fem  # noqa: I001
from helpers import run_mpi
from mpi4py import MPI

import forming  # noqa: F401
from forming.calibrate import tension_assignments
from forming.case import run_case
from forming.errors import InputError
from forming.meso.honeycomb import HoneycombPatch, honeycomb_mesh, patch_box
from forming.meso.inplane import ribbon_walls

# a short, one-layer patch: the walls bend about lines along z, uniformly over the height
CHEAP = ["cells=3,3", "height=5", "layers=1", "strain=0.002", "fracture=false",
         "max_step=1"]


def test_cut_faces_and_their_inner_parts():
    """The cut faces on the patch's rectangle: along x the ribbon walls cut square (each
    2t x H), ``cells[1]`` on each side, the inner part holding the ``cells[1] - 2`` walls a
    pitch from the corners; along y the inclined walls cut at their middles (t / sin 60
    wide), one per column. ``sides`` is still every side face. A failure means the cut
    tagging lost or misplaced faces, and the in-plane runs pull the wrong walls."""
    patch = HoneycombPatch(cells=(3, 4), height=4.0, layers=1)
    md = honeycomb_mesh(patch)
    ds = ufl.Measure("ds", domain=md.mesh, subdomain_data=md.facet_tags)

    def area(name: str) -> float:
        form = fem.form(1.0 * ds(md.facet_tag_ids(name)))
        return md.mesh.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    t, h = patch.cell.wall_thickness, patch.height
    ribbon = patch.cell.ribbon_thickness * h
    for side in ("xmin", "xmax"):
        assert area(f"cut_{side}") == pytest.approx(4 * ribbon, rel=1e-6)
        assert area(f"cut_{side}_inner") == pytest.approx(2 * ribbon, rel=1e-6)
    inclined = t / math.cos(math.radians(30.0)) * h
    for side in ("ymin", "ymax"):
        assert area(f"cut_{side}") == pytest.approx(3 * inclined, rel=1e-6)
    total = area("wall_faces") + sum(area(f"cut_{s}") for s in ("xmin", "xmax", "ymin",
                                                                 "ymax"))
    assert area("sides") == pytest.approx(total, rel=1e-12)
    x0, y0, width, depth = patch_box(patch.cell, *patch.cells)
    walls = ribbon_walls(patch)
    assert len(walls) == 2 * 4 * 2  # 4 columns of ribbon walls (halves at the sides), x 2
    assert walls[:, 0].min() == x0 and walls[:, 0].max() == pytest.approx(x0 + width)


@pytest.fixture(scope="module")
def pulled(tmp_path_factory) -> dict[str, dict]:
    """The cheap patch pulled along x and along y (serial): their summaries."""
    root = tmp_path_factory.mktemp("inplane")
    return {axis: run_case("meso_compression", root / axis, [*CHEAP, f"load=tension_{axis}"])
            for axis in "xy"}


def test_inplane_moduli_are_the_lattice_s(pulled):
    """A regular hexagonal lattice is isotropic in its plane, and in bending its Poisson
    ratio is 1 (Gibson and Ashby; their moduli along x and y are equal, 0.214 MPa for the
    paper's walls). The lattice measures give E_x and E_y within 3% of each other (0.262,
    0.259 MPa: 1%) and Poisson ratios within 0.07 of 1 (1.010, 1.056); the moduli lie
    above Gibson and Ashby's, by less than 30% (22%): their walls bend between junction
    centres, ours between junctions 0.3-0.6 mm thick. The patch's own moduli are off the
    lattice's the way the module says: pulled along x softer (the free sides' dangling
    half walls), along y stiffer (the held ends). On 3 x 3 cells against 5 x 5 (20 mm
    core, 8 layers) the lattice moduli agree within 1.2% (docs/validation.md). A failure
    means the lattice measures (the inner reaction, the ribbon-wall markers) or the cut
    faces changed."""
    m = {axis: s["metrics"] for axis, s in pulled.items()}
    assert all(s["status"] == "completed" for s in pulled.values())
    ex, ey = m["x"]["inplane_modulus_MPa"], m["y"]["inplane_modulus_MPa"]
    ga = m["x"]["gibson_ashby_inplane_MPa"]
    assert ga == pytest.approx(m["y"]["gibson_ashby_inplane_MPa"], rel=1e-12)
    assert ex == pytest.approx(ey, rel=0.03)
    for axis in "xy":
        assert m[axis]["inplane_poisson"] == pytest.approx(1.0, abs=0.07)
        assert 1.0 < m[axis]["inplane_modulus_MPa"] / ga < 1.3
    assert m["x"]["patch_modulus_MPa"] < 0.9 * ex
    assert m["y"]["patch_modulus_MPa"] > 1.05 * ey


@pytest.mark.mpi
def test_inplane_tension_two_ranks_matches_serial(pulled, tmp_path):
    """The lattice measures sum over ranks: pulled along y on 2 ranks, the modulus and the
    Poisson ratio are the serial ones to 1e-6. A failure means a rank-local ribbon-wall
    mean or reaction."""
    args = ["cases/meso_compression.py", "--out", str(tmp_path)]
    for item in [*CHEAP, "load=tension_y"]:
        args += ["--set", item]
    proc = run_mpi(args)
    assert proc.returncode == 0, proc.stderr[-3000:]
    b = json.loads((tmp_path / "summary.json").read_text())
    a = pulled["y"]
    assert b["ranks"] == 2 and b["status"] == "completed"
    for key in ("inplane_modulus_MPa", "inplane_poisson", "patch_modulus_MPa"):
        assert b["metrics"][key] == pytest.approx(a["metrics"][key], rel=1e-6)


@pytest.mark.parametrize(("sets", "field"), [
    (["cells=3,2", "load=tension_x"], "cells"),
    (["cells=1,3", "load=tension_y"], "cells"),
    (["variant=flange", "load=tension_x"], "load"),
    (["stabilisation=0", "load=tension_y"], "load"),
])
def test_inplane_tension_refuses_what_it_cannot_measure(sets, field, tmp_path):
    """A patch without inner rows of ribbon walls, dummy materials, or no stabilisation to
    hold the free rigid motion is refused before any solve, naming the setting."""
    with pytest.raises(InputError, match=field):
        run_case("meso_compression", tmp_path, sets)


def test_calibration_tension_runs_widen_a_small_patch():
    """``forming calibrate`` pulls the compression patch's walls in the plane on at least
    2 x 3 cells, the walls alone, with the stabilisation on, reading the patch's settings
    as the case does; a failure means calibrating a 1 x 1 patch would stop at its
    in-plane runs."""
    sets = tension_assignments("meso_compression",
                               ["cells=1,1", "stabilisation=0", "variant=flange"], "tension_y")
    assert sets[-1] == "stabilisation=0.0002"  # the case's default
    assert "cells=2,3" in sets and "variant=original" in sets
    assert tension_assignments("meso_compression", ["cells=4,5"], "tension_x")[-1] == "cells=4,5"
    assert "cells=3,3" in tension_assignments("meso_compression", [], "tension_x")
    with pytest.raises(InputError, match="cells"):
        tension_assignments("meso_compression", ["cells=a,b"], "tension_x")
