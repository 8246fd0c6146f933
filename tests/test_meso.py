"""Meso-scale honeycomb: the cell geometry, and thin quadratic walls that bend and buckle.

The walls of the meso model are solids with quadratic (27-node) hexahedra, one through
the wall thickness. These tests check that such walls bend as plate theory says and
buckle at the analytic load, before any honeycomb result is trusted.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import ufl
from dolfinx import fem  # noqa: I001
from helpers import history, run_mpi
from mpi4py import MPI

import forming  # noqa: F401
from forming.errors import InputError
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.solids import ElasticSolid
from forming.mesh import box
from forming.meso.checks import WALL_MODULUS as E_WALL
from forming.meso.checks import WALL_POISSON as NU_WALL
from forming.meso.checks import cantilever_ratio, plate_buckling_ratios, square_plate
from forming.meso.honeycomb import HoneycombCell, HoneycombPatch, honeycomb_mesh
from forming.model import Model
from forming.scene import Body, Displacement, Scene
from forming.solver.buckling import buckling_modes
from forming.solver.implicit import ImplicitSolver


def test_cell_density_against_gibson_ashby():
    """The regular cell with double ribbon walls has the solid fraction 1.54 t/l of Gibson
    and Ashby to first order in t/l (their formula counts the junctions twice, so the
    exact polygon is 1.7% lighter at t/l = 0.06); single walls give 1.15 t/l. A patch is a
    period of the lattice, so its fraction is the lattice's to round-off. A failure means
    the cell geometry (offsets, mitres, the patch's cut) is wrong."""
    cell = HoneycombCell()
    tl = cell.wall_thickness / cell.wall_length
    assert cell.relative_density() == pytest.approx(1.54 * tl, rel=0.025)
    single = HoneycombCell(double_walls=False)
    assert single.relative_density() == pytest.approx(2 / math.sqrt(3) * tl, rel=0.025)
    assert cell.relative_density() < 1.54 * tl
    patch = HoneycombPatch(cells=(2, 3))
    assert patch.relative_density() == pytest.approx(cell.relative_density(), rel=1e-9)


def test_honeycomb_mesh_volume_and_faces():
    """The hexahedral mesh holds exactly the walls' volume (section area x height), and
    its bottom and top faces hold the section's area each; an imperfection moves nodes in
    the plane by at most its amplitude and keeps the platens' planes. A failure means the
    mesher lost or doubled part of a wall, or tagged the wrong faces."""
    patch = HoneycombPatch(cells=(2, 2), height=6.0, layers=3, size=0.6)
    md = honeycomb_mesh(patch)
    msh = md.mesh
    area = patch.wall_area()

    def integral(expr) -> float:
        return msh.comm.allreduce(fem.assemble_scalar(fem.form(expr)), op=MPI.SUM)

    ds = ufl.Measure("ds", domain=msh, subdomain_data=md.facet_tags)
    assert integral(1.0 * ufl.dx(domain=msh)) == pytest.approx(area * patch.height, rel=1e-9)
    assert integral(1.0 * ds(md.facet_tag_ids("bottom")[0])) == pytest.approx(area, rel=1e-9)
    assert integral(1.0 * ds(md.facet_tag_ids("top")[0])) == pytest.approx(area, rel=1e-9)
    x = np.zeros((5, 3))
    x[:, 2] = np.linspace(0.0, patch.height, 5)
    moved = HoneycombPatch(cells=(2, 2), height=6.0, imperfection=0.03, seed=3).perturbed(x)
    assert np.abs(moved[[0, -1]] - x[[0, -1]]).max() < 1e-12
    assert np.linalg.norm(moved - x, axis=1).max() <= 0.03 + 1e-12


@pytest.mark.parametrize(("make", "field"), [
    (lambda: HoneycombCell(wall_thickness=-0.3), "cell.wall_thickness"),
    (lambda: HoneycombCell(wall_thickness=5.0), "cell.wall_thickness"),
    (lambda: HoneycombCell(angle_deg=75.0), "cell.angle_deg"),
    (lambda: HoneycombPatch(cells=(0, 3)), "cells"),
    (lambda: HoneycombPatch(layers=0), "layers"),
    (lambda: HoneycombPatch(imperfection=-1.0), "imperfection"),
])
def test_honeycomb_bad_input(make, field):
    """A cell or patch that cannot exist is refused with the field named."""
    with pytest.raises(InputError, match=field):
        make()


def test_cantilever_wall_bends_as_beam_theory():
    """A cantilever strip cut from a cell wall (20 x 2 x 0.3 mm, ten quadratic hexahedra
    along, one through the thickness, aspect ratio 6.7) under a small tip load deflects
    P L^3 / (3 E I) + P L / (kappa G A) within 2% (measured 0.990; free sides, so beam
    theory rather than plate theory). A failure means the quadratic walls lock in bending
    and a honeycomb of them would be too stiff."""
    assert cantilever_ratio(cells=10) == pytest.approx(1.0, abs=0.02)


def test_plate_buckling_load():
    """A simply supported square plate (10 x 10 x 0.2 mm, a quarter with symmetry, 8 x 8
    quadratic hexahedra, one through the thickness) under uniaxial compression buckles at
    k pi^2 E / (12 (1 - nu^2)) (t/b)^2 with k = 4 within 5% (measured 0.977), and its next
    symmetric mode (three half-waves along the load, k = (3 + 1/3)^2) within 5%. A failure
    means the linear buckling analysis (the differential stiffness, SLEPc's eigenvalues)
    or the walls' bending is wrong, and the honeycomb's buckling strains with it."""
    first, second = plate_buckling_ratios(cells=8)
    assert first == pytest.approx(1.0, abs=0.05)
    assert second == pytest.approx(1.0, abs=0.05)


def test_buckling_modes_leave_the_model_undeformed():
    """The buckling analysis returns the model to t = 0 with zero displacement, and scales
    each mode to a largest nodal move of 1 (over all ranks)."""
    model = square_plate(10.0, 0.2, 2)
    modes = buckling_modes(model, ImplicitSolver(model), n_modes=1)
    assert modes.factors[0] > 0
    assert np.allclose(model.bodies["wall"].u.x.array, 0.0) and model.t == 0.0
    peak = float(np.abs(modes.modes[0][0]).max())
    assert model.comm.allreduce(peak, op=MPI.MAX) == pytest.approx(1.0)


def _small_run(folder, *sets: str) -> tuple[dict, np.ndarray]:
    """A 1 x 1 patch, 10 mm high, 3 layers, to 1% strain unless ``sets`` say otherwise:
    its summary's metrics (the run must complete) and its history."""
    from forming.case import run_case

    s = run_case("meso_compression", folder, ["cells=1,1", "height=10", "layers=3",
                                               "strain=0.01", *sets])
    assert s["status"] == "completed", s.get("reason")
    return s["metrics"], np.genfromtxt(folder / "history.csv", delimiter=",", names=True)


def test_meso_compression_modulus_and_stabilised_buckling(tmp_path, pictures):
    """One cell's worth of walls (a 1 x 1 patch, 10 mm high) compressed to 5% nominal
    strain between bonded platens, serial:

    - its initial modulus is Gibson and Ashby's E_s x relative density within 5% (the
      walls carry the load axially; measured +0.9%, the bonded ends' Poisson restraint);
    - the walls buckle on the way and the viscous stabilisation carries the run through
      (status completed), dissipating less than 1% of the internal work;
    - the internal work of the linear first steps is 1/2 F delta (1e-6: the trapezoidal
      rule is exact on a straight line), so the energy books are right;
    - the walls' largest tensile strain is reported against the fracture strain.

    A failure means the meso walls or the stabilisation changed: a stiffer modulus points
    at the mesh or the walls' thickness, a failed run at the stabilisation.
    """
    m, h = _small_run(tmp_path, "strain=0.05")
    assert m["modulus_MPa"] == pytest.approx(m["gibson_ashby_modulus_MPa"], rel=0.05)
    assert m["peak_stress_MPa"] > 0 and 0 < m["max_wall_strain"] < 0.5
    dissipated, work = h["stabilisation_energy_Nmm"][-1], h["internal_work_Nmm"][-1]
    assert 0 < dissipated < 0.01 * work
    stroke, force = h["stroke_mm"][1], -h["reaction_top_z_N"][1]
    assert h["internal_work_Nmm"][1] == pytest.approx(0.5 * force * stroke, rel=1e-6)
    assert (tmp_path / "stress_strain.png").is_file() and (tmp_path / "folded_walls.png").is_file()


def test_meso_compression_with_a_touching_platen(tmp_path):
    """The paper's original meso model: the top platen a rigid frictional tool (mu 0.36)
    that touches the wall edges instead of holding them. Up to 1% strain (before the walls
    buckle) the walls stand on it as on a bonded platen: the modulus is Gibson and Ashby's
    within 5%, with the contact's penetration inside its tolerance. A failure means the
    contact of a quadratic body with a tool (nodal Gauss-Lobatto quadrature) misbehaves."""
    m, h = _small_run(tmp_path, "platen=contact")
    assert m["modulus_MPa"] == pytest.approx(m["gibson_ashby_modulus_MPa"], rel=0.05)
    assert h["force_platen_z_N"][-1] > 0


def test_meso_compression_with_the_dummy_infill(tmp_path):
    """The paper's dummy infill (Table 3: E 0.3 MPa, nu 0) fills the pores, bonded to the
    walls: to 1% strain the patch's modulus is the rule of mixtures of walls and infill,
    E_s rho + E_infill (1 - rho), within 5% (the infill adds 0.7% to the walls' 37.2 MPa),
    and the walls and the infill each carry their share of the platen force. A failure
    means the two-body meso model (regions, the bonded wall-infill interface) is wrong."""
    m, h = _small_run(tmp_path, "variant=infill")
    rho = m["relative_density"]
    assert m["modulus_MPa"] == pytest.approx(m["gibson_ashby_modulus_MPa"]
                                             + 0.3 * (1 - rho), rel=0.05)
    walls, infill = -h["reaction_walls_top_z_N"][-1], -h["reaction_infill_infill_top_z_N"][-1]
    assert 0 < infill < 0.05 * walls


def test_meso_compression_with_dummy_flanges(tmp_path):
    """The paper's dummy flanges (Table 3: E 4 MPa, nu 0.21; 1 mm wide, 0.3 mm thick along
    the walls' top edges, bonded to them), platens bonded: to 1% strain the patch keeps
    the walls' modulus (Gibson and Ashby within 5%: the flanges are a thin soft cap), and
    the top platen pulls on the flanges too. A failure means the flange region (a top
    layer of its own, its faces) or its coupling to the walls is wrong."""
    m, h = _small_run(tmp_path, "variant=flange")
    assert m["modulus_MPa"] == pytest.approx(m["gibson_ashby_modulus_MPa"], rel=0.05)
    walls, flange = -h["reaction_walls_top_z_N"][-1], -h["reaction_flange_flange_top_z_N"][-1]
    assert walls > 0 and flange != 0.0


@pytest.mark.mpi
def test_meso_compression_two_ranks_matches_serial(tmp_path):
    """Before the walls buckle (1% strain) the path is the same on any number of ranks:
    mpirun -n 2 gives the serial platen force to 1e-6 relative, on the same load steps,
    and the same linear buckling strain to 1e-6. A failure means a rank-dependent
    honeycomb mesh (the imperfection, the tags) or buckling analysis."""
    from forming.case import run_case

    sets = ["cells=1,1", "height=10", "layers=2", "strain=0.01", "buckling=true"]
    serial, parallel = tmp_path / "serial", tmp_path / "parallel"
    a = run_case("meso_compression", serial, sets)
    args = ["cases/meso_compression.py", "--out", str(parallel)]
    for item in sets:
        args += ["--set", item]
    proc = run_mpi(args)
    assert proc.returncode == 0, proc.stderr[-3000:]
    b = json.loads((parallel / "summary.json").read_text())
    assert b["status"] == "completed" and b["ranks"] == 2
    assert b["metrics"]["buckling_strain"] == pytest.approx(a["metrics"]["buckling_strain"],
                                                            rel=1e-6)
    ha = np.genfromtxt(serial / "history.csv", delimiter=",", names=True)
    hb = np.genfromtxt(parallel / "history.csv", delimiter=",", names=True)
    np.testing.assert_allclose(hb["t"], ha["t"], rtol=0, atol=1e-12)
    fa, fb = ha["reaction_top_z_N"], hb["reaction_top_z_N"]
    assert np.max(np.abs(fb - fa)) <= 1e-6 * np.max(np.abs(fa))


def test_stabilisation_input_and_solver():
    """A stabilisation fraction outside (0, 1) or naming an unknown body is refused with
    the field named, and an explicit run refuses it (its damping is explicit.damping)."""
    from forming.scene import Stabilisation
    from forming.solver.explicit import ExplicitSolver

    with pytest.raises(InputError, match="stabilisation.fraction"):
        Stabilisation(fraction=0.0)
    mesh = box((1.0, 1.0, 1.0), (1, 1, 1))
    body = Body("wall", ElasticSolid(IsotropicElasticity(E_WALL, NU_WALL), density=7e-10))
    with pytest.raises(InputError, match="stabilisation.bodies"):
        Scene(name="s", mesh=mesh, bodies=(body,), stabilisation=Stabilisation(bodies=("x",)))
    scene = Scene(name="s", mesh=mesh, bodies=(body,),
                  displacements=(Displacement("wall", "bottom", x=0.0, y=0.0, z=0.0),),
                  stabilisation=Stabilisation())
    with pytest.raises(InputError, match="scene.stabilisation"):
        ExplicitSolver(Model(scene, penalty_only=True))


@pytest.mark.slow
@pytest.mark.mpi
def test_fracturing_walls_peak_and_soften(tmp_path):
    """One cell's worth of fracturing walls (a 1 x 1 patch, the default 20 mm and mesh)
    on 2 ranks, to 10% nominal strain: the walls buckle, their folds break at the 0.067
    strain of Table 1, and the curve peaks and falls, as the measured core's does.

    Checks: a peak between 3% and 8% strain; at 10% the stress is below 75% of the peak;
    the fracture dissipated energy; the stabilisation stayed below 5% of the internal work.
    A failure means the damage law no longer softens the folds (no peak, as with elastic
    walls), or the run stopped before 10% (the implicit solver lost the post-peak path).
    About 4 minutes on 2 cores: ``scripts/dev.sh validate``.
    """
    r = run_mpi(["cases/meso_compression.py", "--out", str(tmp_path), "--set", "cells=1,1",
                 "--set", "strain=0.1"], n=2, timeout=1200)
    assert r.returncode == 0, r.stderr[-2000:]
    m = json.loads((tmp_path / "summary.json").read_text())["metrics"]
    assert 0.03 < m["peak_strain"] < 0.08
    assert m["final_stress_MPa"] < 0.75 * m["peak_stress_MPa"]
    assert m["fracture_energy_Nmm"] > 0.0
    h = history(tmp_path)
    assert h["stabilisation_energy_Nmm"][-1] < 0.05 * h["internal_work_Nmm"][-1]


@pytest.mark.slow
def test_meso_crushing_stays_under_the_punch(tmp_path):
    """The square punch on a 2 x 2 patch of walls, explicit, to 2% of the core's
    thickness (elastic walls still): the wall tops under the punch's flat face go down
    with it, those outside the punch by less than a fifth of that (the paper: crushing
    has a negligible effect outside the punch). A failure means the punch does not
    carry the walls (the tool contact of quadratic walls) or the patch shears as a block.
    About 3 minutes on one core: ``scripts/dev.sh validate``.
    """
    from forming.case import run_case

    s = run_case("meso_crushing", tmp_path, ["stroke=0.02"])
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    travel = 0.02 * 10.0
    assert m["settlement_inside_mm"] == pytest.approx(travel, rel=0.05)
    assert m["settlement_outside_mm"] < 0.2 * m["settlement_inside_mm"]
    assert m["punch_force_max_N"] > 0


def test_wall_columns_measure_a_uniform_squeeze():
    """The meso hemisphere's compaction pairs each wall-top node with the bottom node
    below it: on a 2 x 1 patch (quadratic walls, seeded imperfection) squeezed by
    u_z = -0.1 z, every column's compaction, one minus its height over the initial one,
    is 0.1 to round-off, and the columns cover the top face's nodes. A failure means
    top and bottom nodes are paired across walls (the case's compaction is then noise).
    """
    from types import SimpleNamespace

    from forming.meso.post import wall_columns

    height = 3.0
    md = honeycomb_mesh(HoneycombPatch(HoneycombCell(), (2, 1), height, 1.0, 2, 0.05))
    V = fem.functionspace(md.mesh, ("Lagrange", 2, (3,)))
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], -0.1 * x[2]]))
    xy, top, bottom = wall_columns(SimpleNamespace(V=V, u=u, mesh=md.mesh), height)
    n_top = md.mesh.comm.allreduce(int(np.sum(np.isclose(
        V.tabulate_dof_coordinates()[:V.dofmap.index_map.size_local, 2], height))))
    assert len(xy) == n_top > 0
    np.testing.assert_allclose(1.0 - (top - bottom) / height, 0.1, atol=1e-12)


def test_meso_hemisphere_refuses_a_patch_inside_the_die():
    """A patch too small to rest on the die (2 x 2 cells against a 21.6 mm opening) is
    refused by name, before any run."""
    from forming.case import load_case, prepare_case

    module = load_case("meso_hemisphere")
    with pytest.raises(InputError, match="--set cells"):
        prepare_case("meso_hemisphere", ["cells=2,2"], module.build, module.Params)


def test_held_nodes_leave_out_what_only_eroded_cells_hold():
    """A row of 4 x 1 x 1 cells with the cells at x < 2 eroded: the nodes at x < 1 (only
    eroded cells hold them) float, those at x >= 2 (a live cell holds them) do not,
    whichever rank owns the node or the cells. A failure means the crushing metrics
    count floating fragments as wall tops (settlement beyond the punch's travel).
    """
    from types import SimpleNamespace

    from forming.meso.post import held_nodes

    md = box((4.0, 1.0, 1.0), (4, 1, 1))
    V = fem.functionspace(md.mesh, ("Lagrange", 1, (3,)))
    n_cells = md.mesh.topology.index_map(3).size_local
    cells = np.arange(n_cells, dtype=np.int32)
    from dolfinx.mesh import compute_midpoints

    live = compute_midpoints(md.mesh, 3, cells)[:, 0] > 2.0
    body = SimpleNamespace(V=V, point_cells=cells, live_cells=lambda: live)
    held = held_nodes(body)
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local, 0]
    assert np.all(held[x > 1.99]) and not np.any(held[x < 1.01])
