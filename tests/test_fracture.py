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
