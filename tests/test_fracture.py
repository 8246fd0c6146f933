"""The fracturing wall material: its softening law, its tangent and its crack band."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import block_scene, body_taylor

from forming.errors import InputError
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.fracture import FracturingSolid
from forming.materials.solids import evaluate
from forming.meso.checks import crack_band_bar
from forming.model import Model

CARDBOARD = IsotropicElasticity(410.0, 0.21)  # Table 1


def _uniaxial_path(material, band, strains):
    """Hencky axial stress T along a uniaxial-strain path (lateral stretches 1)."""
    hist, kappa = np.zeros((1, 6)), np.zeros(1)
    ginv = np.eye(3).reshape(1, 9) / band  # a cube of side ``band``
    out = []
    for e in strains:
        c = np.diag([np.exp(2 * e), 1.0, 1.0]).reshape(1, 9)
        r = evaluate(material, c, hist, kappa, cells=(ginv, 1))
        hist, kappa = r.ep, r.evp
        out.append(r.S[0, 0] * np.exp(2 * e))  # T = S lambda^2 on the axis
    return np.array(out), hist


def test_softening_law_and_dissipation_at_a_point():
    """Uniaxial strain (nu 0): T = E e up to the fracture strain 0.067, then the linear
    softening of the crack band (E e (1 - d) falls to 0 at eps_u = 2 G_f / (sigma_f h)),
    and the dissipated density equals d_max sigma_f eps_u / 2 once the point is spent.

    A failure means the damage law or its energy bookkeeping (trapezoidal in d) is off.
    """
    m = FracturingSolid(IsotropicElasticity(410.0, 0.0), fracture_energy=7.4)
    band = 1.0
    eps_u = 2 * m.fracture_energy / (m.fracture_stress * band)
    strains = np.linspace(0.0, 1.2 * eps_u, 400)
    t, hist = _uniaxial_path(m, band, strains)
    sf, ef = m.fracture_stress, m.fracture_strain
    d = np.clip(1 - ef * (eps_u - strains) / (strains * (eps_u - ef) + 1e-300), 0, 1)
    expected = np.where(strains <= ef, 410.0 * strains,
                        410.0 * strains * (1 - m.max_damage * d))
    assert t == pytest.approx(expected, rel=1e-9, abs=1e-9)
    assert hist[0, 1] == pytest.approx(band)
    assert hist[0, 2] == pytest.approx(m.max_damage * 0.5 * sf * eps_u, rel=2e-3)


def test_fracturing_solid_input():
    """Bad parameters are named (a negative fracture energy, damage outside (0, 1))."""
    with pytest.raises(InputError, match="fracture_energy"):
        FracturingSolid(CARDBOARD, fracture_energy=-1.0)
    with pytest.raises(InputError, match="max_damage"):
        FracturingSolid(CARDBOARD, max_damage=1.0)
    with pytest.raises(InputError, match="fracture_strain"):
        FracturingSolid(CARDBOARD, fracture_strain=0.0)


@pytest.mark.parametrize("sign", [-1.0, 1.0], ids=["compression", "tension"])
def test_deletion_strain_erodes_in_compression_and_tension(sign):
    """A point with a deletion strain (the paper's dummies, Table 3: 0.010) keeps its
    elastic stress below it and carries nothing from the step after it reached it, in
    uniaxial compression as in tension; without one, compression never erodes.

    Uniaxial strain (nu 0, Hencky): T = E e until |e| = 0.010 (in tension the band
    starts to soften there too), then 0 (the point is flagged in the step that reaches
    it, stress-free from the next). A failure means
    deletion misses compression (our crack band is tension-driven) or comes late.
    """
    m = FracturingSolid(IsotropicElasticity(0.3, 0.0), fracture_strain=0.010,
                        fracture_energy=1.0, deletion_strain=0.010, erosion=True)
    strains = sign * np.array([0.002, 0.006, 0.0099, 0.0101, 0.012, 0.02])
    t, hist = _uniaxial_path(m, 1.0, strains)
    assert t[:3] == pytest.approx(0.3 * strains[:3], rel=1e-9)
    # past 0.010 in tension the crack band has begun to soften as well (1% here)
    assert t[3] == pytest.approx(0.3 * strains[3], rel=1e-9 if sign < 0 else 0.02)
    assert np.all(t[4:] == 0.0)
    assert hist[0, 4] == 1.0
    kept = FracturingSolid(IsotropicElasticity(0.3, 0.0), fracture_strain=0.010,
                           fracture_energy=1.0, erosion=True)
    t_kept, hist_kept = _uniaxial_path(kept, 1.0, -np.abs(strains))
    assert t_kept == pytest.approx(-0.3 * np.abs(strains), rel=1e-9)
    assert hist_kept[0, 4] == 0.0
    with pytest.raises(InputError, match="deletion_strain"):
        FracturingSolid(CARDBOARD, deletion_strain=-0.01)


@pytest.mark.parametrize("rule", ["all", "first", "half"])
def test_an_element_is_deleted_with_its_last_first_or_half_its_points(rule):
    """Three cells of 8 points each under a deletion strain of 0.010: one point of the
    first cell and four of the second are stretched past it, every other point stays at
    0.002. With ``element_deletion="all"`` only those five points are eroded; with
    ``"first"`` (Abaqus/Explicit's solid element deletion) every point of the first two
    cells; with ``"half"`` (LS-DYNA's VOLFRAC 0.5) every point of the second cell and the
    one of the first. Eroded points carry nothing from the next step on; the third cell is
    untouched. A failure means the rule erodes a neighbouring cell, misses points of its
    own, counts the share wrongly, or erodes too early.
    """
    m = FracturingSolid(IsotropicElasticity(0.3, 0.0), fracture_strain=0.010,
                        fracture_energy=1.0, deletion_strain=0.010, erosion=True,
                        element_deletion=rule)
    strains = np.full(24, 0.002)
    failed = np.zeros(24, dtype=bool)
    failed[[5, 8, 10, 13, 15]] = True
    strains[failed] = 0.02
    c = np.array([np.diag([np.exp(2 * e), 1.0, 1.0]).ravel() for e in strains])
    cells = (np.tile(np.eye(3).reshape(1, 9), (3, 1)), 8)
    first = evaluate(m, c, np.zeros((24, 6)), np.zeros(24), cells=cells)
    assert np.all(first.S[~failed, 0] > 0.0)  # still carrying in this step
    eroded = first.ep[:, 4] == 1.0
    cell = np.arange(24) // 8
    want = {"all": failed, "first": cell < 2, "half": failed | (cell == 1)}[rule]
    assert np.array_equal(eroded, want)
    after = evaluate(m, c, first.ep, first.evp, cells=cells)
    assert np.all(after.S[want] == 0.0) and np.all(after.S[~want, 0] > 0.0)
    with pytest.raises(InputError, match="element_deletion"):
        FracturingSolid(CARDBOARD, element_deletion="any")


def test_damage_jacobian_taylor():
    """Taylor test of the FE Jacobian of a block softening in tension (every point on the
    softening branch, loading): slopes 1 and 2.

    A second-remainder slope of 1 would mean the damage term -S+ (x) dd/dE or the
    split's eigenframe stiffness is wrong.
    """
    model = Model(block_scene(FracturingSolid(CARDBOARD), stroke=1.0))
    body = model.body
    body.plastic.ep[:, 1] = 5.0  # crack band (the cells' size): eps_u = 0.108
    body.plastic.evp[:] = 0.08  # largest principal strain reached so far
    body.plastic.restore(body.plastic.snapshot())
    x = body.V.tabulate_dof_coordinates()
    u0 = np.zeros((x.shape[0], 3))
    u0[:, 2] = 0.1 * x[:, 2]
    u0[:, :2] = -0.03 * x[:, :2]  # lateral contraction: no principal strain near 0 (kink)
    u0 = u0.ravel() + np.random.default_rng(5).normal(size=u0.size) * 1e-3
    body.u.x.array[:] = u0
    body.invalidate()
    body.update_material()
    assert body.plastic.evp_trial.min() > 0.08  # every point loads
    assert 0.0 < body.plastic.ep_trial[:, 0].min()
    s1, s2 = body_taylor(model, u0)
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(np.abs(s2 - 2.0) < 0.15), s2


def test_crack_band_energy_is_mesh_independent(tmp_path):
    """A bar (4 mm, quadratic hexahedra, nu 0) pulled apart: the crack forms in its
    slightly thinner middle element, whatever the mesh (3 or 9 elements along), and
    dissipates G_f x section (times max_damage) within 2%.

    Without the crack band the dissipated energy would scale with the element length
    (a factor 3 between these meshes). A failure means the band width or the softening
    law is wrong, or the crack spread over more than one element.
    """
    for cells in (3, 9):
        r = crack_band_bar(tmp_path / str(cells), cells, degree=2, weakening=0.05,
                           stretch=3.0)
        assert r.band == pytest.approx(4.0 / cells, rel=1e-3)
        assert r.dissipated == pytest.approx(r.expected, rel=0.02), cells
        assert r.force[-1] < 0.1 * r.force.max()  # broken


def test_viscous_damage_follows_with_its_lag():
    """With a damage viscosity eta [mm of travel], a step of travel s closes the share
    w / (1 + w), w = s / eta, of the gap to the rate-independent damage (backward Euler
    of Duvaut-Lions), and its tangent is the rate-independent one scaled by that share
    (central difference, 1e-6). A failure means the regularisation no longer converges
    to the rate-independent law as eta -> 0, or its tangent is inconsistent.
    """
    fast = FracturingSolid(IsotropicElasticity(410.0, 0.0))
    slow = FracturingSolid(IsotropicElasticity(410.0, 0.0), viscosity=0.5)
    c = np.diag([np.exp(2 * 0.09), 1.0, 1.0]).reshape(1, 9)
    hist, kappa = np.zeros((1, 6)), np.array([0.08])
    hist[0, 1] = 1.0  # a band of 1 mm: eps_u = 0.54
    ginv = (np.eye(3).reshape(1, 9), 1)
    d_fast = evaluate(fast, c, hist, kappa, cells=ginv).ep[0, 0]
    r = evaluate(slow, c, hist, kappa, cells=ginv, load_increment=0.1, travel=2.0)
    share = 0.4 / 1.4  # travel 0.2 mm over 0.5 mm
    assert r.ep[0, 0] == pytest.approx(share * d_fast, rel=1e-12)
    h = 1e-6
    dc = np.diag([2 * h, 0.0, 0.0]).reshape(1, 9)  # dE_11 = h
    sp = evaluate(slow, c + dc, hist, kappa, cells=ginv, load_increment=0.1, travel=2.0).S
    sm = evaluate(slow, c - dc, hist, kappa, cells=ginv, load_increment=0.1, travel=2.0).S
    assert r.D.reshape(6, 6)[0, 0] == pytest.approx((sp - sm)[0, 0] / (2 * h), rel=1e-6)


def _plate_on_block(tmp, layers: int, eroded_above: float | None, approach: float):
    """A 2 x 2 mm column of ``layers`` 1 mm layers of quadratic hexahedra (E 100 MPa,
    nu 0, erosion on) on a clamped base, under a frictionless plate on its top face that
    moves down by ``approach`` mm over the first half of the load (slowing down over its
    last 0.5%, so that it does not strike what it meets) and by 0.01 mm more over the
    second half (explicit); the cells above ``eroded_above`` [mm] are eroded before the
    first step. Returns the summary and the history."""
    from dolfinx.mesh import compute_midpoints

    from forming.contact.shapes import Plane
    from forming.job import Job
    from forming.mesh import box
    from forming.scene import Body, Contact, Displacement, Scene, Table, Tool
    from forming.simulation import Simulation
    from forming.solver.options import ExplicitOptions
    from forming.solver.stepping import StepControl

    height = float(layers)
    solid = FracturingSolid(IsotropicElasticity(100.0, 0.0), erosion=True, density=1e-9)
    scene = Scene("column", box((2.0, 2.0, height), (2, 2, layers)),
                  (Body("column", solid, degree=2),),
                  displacements=(Displacement("column", "bottom", x=0.0, y=0.0, z=0.0),),
                  tools=(Tool("plate", Plane((0.0, 0.0, height), (0.0, 0.0, -1.0)),
                              z=Table((0.0, 0.4, 0.5, 1.0), (0.0, -0.995 * approach,
                                                             -approach, -approach - 0.01))),),
                  contacts=(Contact("column", "top", "plate"),))
    job = Job(scene, steps=StepControl(initial=0.1, max=0.1, min=0.1), solver="explicit",
              explicit=ExplicitOptions(loading_time=1e-3))
    sim = Simulation(job, tmp, "column")
    if eroded_above is not None:
        body = sim.model.body
        cells = body.point_cells
        mid = compute_midpoints(body.mesh, 3, cells.astype(np.int32))[:, 2]
        per_cell = body.n_points // max(len(cells), 1)
        body.plastic.ep[np.repeat(mid > eroded_above, per_cell), 4] = 1.0
        body.plastic.restore(body.plastic.snapshot())
    summary = sim.run()
    return summary, np.genfromtxt(tmp / "history.csv", delimiter=",", names=True)


def test_explicit_tool_meets_the_faces_erosion_uncovers(tmp_path):
    """A plate pressed through the eroded top layer of a 3-layer column meets the faces the
    erosion uncovered: moved through the eroded layer's 1 mm, then 0.01 mm into the rest,
    it carries the force of the 2-layer column pressed by 0.01 mm within 0.1% (both
    explicit, the same second half; E A d / 2 = 2 N less the penalty's compliance). The
    reported penetration is the live surface's (within 5% of the 2-layer column's), not
    that of the eroded layer's top, which the plate crossed.

    Before the contact followed erosion, the plate met only the top faces, which lie on
    eroded cells: the force was 0 and the plate passed through (meso_crushing's punch
    fell through the crushed walls). A failure means the uncovered faces are not found,
    or their nodal areas are wrong.
    """
    s2, two = _plate_on_block(tmp_path / "two", 2, None, 0.0)
    s3, three = _plate_on_block(tmp_path / "three", 3, 2.0, 1.0)
    assert s2["status"] == s3["status"] == "completed"
    force = three["force_plate_z_N"][-1]
    assert force == pytest.approx(two["force_plate_z_N"][-1], rel=1e-3)
    assert force == pytest.approx(100.0 * 4.0 * 0.01 / 2.0, rel=0.1)
    # the penetration of the live surface, not of the eroded layer's top the plate crossed
    assert three["max_penetration_mm"][-1] == pytest.approx(two["max_penetration_mm"][-1],
                                                            rel=0.05)
