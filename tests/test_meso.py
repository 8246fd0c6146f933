"""Meso-scale honeycomb: the cell geometry, and thin quadratic walls that bend and buckle.

The walls of the meso model are solids with quadratic (27-node) hexahedra, one through
the wall thickness. These tests check that such walls bend as plate theory says and
buckle at the analytic load, before any honeycomb result is trusted.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

import forming  # noqa: F401
from forming.errors import InputError
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.solids import ElasticSolid
from forming.mesh import box
from forming.meso.honeycomb import HoneycombCell, HoneycombPatch, honeycomb_mesh
from forming.model import Model
from forming.scene import Body, Displacement, Linear, Scene, Traction
from forming.solver.buckling import buckling_modes
from forming.solver.implicit import ImplicitSolver

E_WALL, NU_WALL = 410.0, 0.21  # the paper's Table 1 (cardboard cell walls)


def _wall(mesh, displacements, tractions) -> Model:
    material = ElasticSolid(IsotropicElasticity(E_WALL, NU_WALL))
    return Model(Scene(name="wall", mesh=mesh, bodies=(Body("wall", material, degree=2),),
                       displacements=displacements, tractions=tractions))


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
    L, b, t = 20.0, 2.0, 0.3
    load = 1e-5  # MPa on the tip face: a deflection of 0.03 t, linear
    model = _wall(box((L, b, t), (10, 1, 1)),
                  (Displacement("wall", "xmin", x=0.0, y=0.0, z=0.0, reaction=False),),
                  (Traction("wall", "xmax", z=Linear(-load)),))
    solver = ImplicitSolver(model)
    solver.advance(0.0, 1.0, 0.0)
    assert solver.solve().converged
    body = model.bodies["wall"]
    n = body.V.dofmap.index_map.size_local
    X = body.V.tabulate_dof_coordinates()[:n]
    tip = np.isclose(X[:, 0], L)
    uz = body.u.x.array.reshape(-1, 3)[:n, 2]
    comm = model.comm
    deflection = -comm.allreduce(uz[tip].sum()) / comm.allreduce(int(tip.sum()))
    P, inertia = load * b * t, b * t**3 / 12
    G = E_WALL / (2 * (1 + NU_WALL))
    expected = P * L**3 / (3 * E_WALL * inertia) + P * L / (5 / 6 * G * b * t)
    assert deflection == pytest.approx(expected, rel=0.02)


def test_plate_buckling_load():
    """A simply supported square plate (10 x 10 x 0.2 mm, a quarter with symmetry, 8 x 8
    quadratic hexahedra, one through the thickness) under uniaxial compression buckles at
    k pi^2 E / (12 (1 - nu^2)) (t/b)^2 with k = 4 (one half-wave each way) within 5%
    (measured 0.977), and its next symmetric mode (three half-waves along the load, k =
    (3 + 1/3)^2) within 5%. A failure means the linear buckling analysis (the differential
    stiffness, SLEPc's eigenvalues) or the walls' bending is wrong, and the honeycomb's
    buckling peak and imperfection modes with it."""
    a, t = 10.0, 0.2
    model = _wall(box((a / 2, a / 2, t), (8, 8, 1)),
                  (Displacement("wall", "xmin", x=0.0, reaction=False),
                   Displacement("wall", "ymin", y=0.0, reaction=False),
                   Displacement("wall", "xmax", z=0.0, reaction=False),
                   Displacement("wall", "ymax", z=0.0, reaction=False)),
                  (Traction("wall", "xmax", x=Linear(-1.0)),))
    modes = buckling_modes(model, ImplicitSolver(model), n_modes=2)
    plate = math.pi**2 * E_WALL / (12 * (1 - NU_WALL**2)) * (t / a) ** 2
    assert modes.factors[0] == pytest.approx(4.0 * plate, rel=0.05)
    assert modes.factors[1] == pytest.approx((3 + 1 / 3) ** 2 * plate, rel=0.05)
    assert np.allclose(model.bodies["wall"].u.x.array, 0.0)  # left undeformed
    peak = max(np.abs(m[0]).max() for m in modes.modes)
    assert model.comm.allreduce(peak, op=MPI.MAX) == pytest.approx(1.0)
