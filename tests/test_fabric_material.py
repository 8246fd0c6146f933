"""NCF skin material: the picture-frame shear curve and the UFL fabric energy.

UFL expressions are evaluated at homogeneous deformation gradients held in ``fem.Constant``s,
through one ``fem.Expression`` per material (one JIT compilation each) and, once, through
an assembled scalar form on a one-cell unit cube.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import ufl

from forming.errors import InputError
from forming.materials.fabric import COLUMNS, NonCrimpFabric, ShearCurve

DEG = math.pi / 180.0
POS = (0.02, 0.045, 0.08, 0.15, 0.25, 0.40, 0.65, 1.0)  # material-data.md estimates
NEG = (0.006, 0.012, 0.022, 0.04, 0.06, 0.10, 0.20, 0.40)
ANGLES = (10.0, 20.0, 30.0, 40.0, 45.0, 50.0, 55.0, 60.0)


class Probe:
    """Evaluates a fabric's UFL quantities at a homogeneous F (and a scalar gamma)."""

    def __init__(self, mat: NonCrimpFabric):
        # forming (imported above) has loaded dolfinx_solver, so dolfinx may come now
        from dolfinx import fem, mesh
        from mpi4py import MPI

        self.mat, self.fem = mat, fem
        self.msh = mesh.create_unit_cube(MPI.COMM_SELF, 1, 1, 1)
        self.Fc = fem.Constant(self.msh, np.eye(3))
        self.dFc = fem.Constant(self.msh, np.zeros((3, 3)))
        self.gc = fem.Constant(self.msh, 0.0)
        F = ufl.variable(self.Fc)
        psi = mat.energy(F)
        P = ufl.diff(psi, F)
        i, j, k, m = ufl.indices(4)
        a_df = ufl.as_tensor(ufl.diff(P, F)[i, j, k, m] * self.dFc[k, m], (i, j))
        p_mem = ufl.diff(mat.membrane_energy(F), F)
        gam = mat.shear_angle(F)
        g = ufl.variable(self.gc)
        w = mat.shear.energy_ufl(g)
        scalars = [psi, mat.membrane_energy(F), mat.matrix_energy(F), gam,
                   *mat.fibre_stretches(F), mat.wrinkling_indicator(gam),
                   mat.shear.energy_ufl(gam) / mat.thickness,
                   mat.shear.torque_ufl(g), w, ufl.diff(w, g)]
        self.names = ["psi", "mem", "mat", "gamma", "lam1", "lam2", "wrinkle", "ws_t",
                      "torque", "energy", "dwdg"]
        comps = [t[a, b] for t in (P, p_mem, a_df) for a in range(3) for b in range(3)]
        self.expr = fem.Expression(ufl.as_vector(scalars + comps), np.array([[0.5, 0.5, 0.5]]))
        self.cells = np.array([0], dtype=np.int32)
        self.psi = psi

    def __call__(self, F=None, dF=None, gamma=0.0) -> dict:
        self.Fc.value = np.eye(3) if F is None else F
        self.dFc.value = np.zeros((3, 3)) if dF is None else dF
        self.gc.value = gamma
        v = self.expr.eval(self.msh, self.cells).ravel()
        n = len(self.names)
        out = dict(zip(self.names, v[:n], strict=True))
        out["P"], out["Pmem"], out["AdF"] = (v[n + 9 * q:n + 9 * q + 9].reshape(3, 3)
                                             for q in range(3))
        return out


@pytest.fixture(scope="module")
def fabric() -> NonCrimpFabric:
    return NonCrimpFabric()


@pytest.fixture(scope="module")
def probe(fabric) -> Probe:
    return Probe(fabric)


def rotation(axis, angle) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def picture_frame(mat: NonCrimpFabric, gamma: float, thickness_stretch: float = 1.0):
    """F that turns the fibres towards each other by gamma/2 each, without stretching them."""
    a1, a2 = mat.fibre_directions
    t1, t2 = np.radians(mat.fibre_angles_deg)
    s = math.copysign(1.0, math.sin(t1 - t2))  # fibre 1 is anticlockwise from fibre 2
    b1 = np.array([math.cos(t1 - s * gamma / 2), math.sin(t1 - s * gamma / 2)])
    b2 = np.array([math.cos(t2 + s * gamma / 2), math.sin(t2 + s * gamma / 2)])
    F = np.eye(3) * thickness_stretch
    F[:2, :2] = np.column_stack([b1, b2]) @ np.linalg.inv(np.column_stack([a1[:2], a2[:2]]))
    return F


def test_default_curve_is_the_shipped_estimate():
    c = ShearCurve.default()
    assert c.shear_deg == ANGLES and c.force_positive == POS and c.force_negative == NEG
    assert c.source.endswith("fabric_picture_frame_estimate.csv")
    text = Path(c.source).read_text()
    assert "ESTIMATES" in text and "material-data.md" in text
    assert NonCrimpFabric().shear == c


def test_zero_energy_and_stress_at_identity(probe):
    r = probe()
    assert abs(r["psi"]) < 1e-14 and abs(r["gamma"]) < 1e-14
    assert r["lam1"] == pytest.approx(1.0, abs=1e-15) and r["lam2"] == pytest.approx(1.0)
    assert np.max(np.abs(r["P"])) < 1e-12
    assert r["wrinkle"] == 0.0


@pytest.mark.parametrize("deg", [-65.0, -50.5, -30.0, -10.0, -1.0, 1.0, 10.0, 25.0, 42.5, 65.0])
def test_picture_frame_shear_angle_and_energy(probe, fabric, deg):
    """Pure fibre rotation: the signed angle comes back and psi_membrane = W_s(gamma)/t."""
    g = deg * DEG
    for stretch in (1.0, 1.0 / math.cos(g)):  # thickness held, or thickened at constant volume
        r = probe(picture_frame(fabric, g, stretch))
        assert r["gamma"] == pytest.approx(g, abs=1e-12)
        assert r["lam1"] == pytest.approx(1.0, abs=1e-13)
        assert r["lam2"] == pytest.approx(1.0, abs=1e-13)
        ws_t = fabric.shear.energy(g) / fabric.thickness
        assert r["mem"] == pytest.approx(ws_t, rel=1e-10)
        assert r["psi"] - r["mat"] == pytest.approx(ws_t, rel=1e-10)
        assert r["ws_t"] == pytest.approx(ws_t, rel=1e-12)
        assert r["wrinkle"] == (1.0 if deg > 42.0 or deg < -50.0 else 0.0)


def test_sign_convention_stretch_along_stitch_is_positive(probe):
    """Default +/-45 deg fibres: stretching along x (the 0 deg stitch) is positive shear."""
    expect = math.pi / 2 - 2 * math.atan(1 / 1.1**2)  # 10.85 deg
    assert probe(np.diag([1.1, 1 / 1.1, 1.0]))["gamma"] == pytest.approx(expect, rel=1e-12)
    assert probe(np.diag([1 / 1.1, 1.1, 1.0]))["gamma"] == pytest.approx(-expect, rel=1e-12)


def test_curve_torque_energy_and_data(probe):
    c = ShearCurve.default()
    x = np.radians(ANGLES)
    # the torque passes through the data, F_norm cos(gamma), on both branches
    np.testing.assert_allclose(c.torque(x), np.array(POS) * np.cos(x), rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.torque(-x), -np.array(NEG) * np.cos(x), rtol=0, atol=1e-12)
    g = np.radians(np.linspace(-75.0, 75.0, 3001))
    t, w = c.torque(g), c.energy(g)
    assert np.all(np.diff(t) >= 0) and np.all(w >= 0)  # shape preserved, energy >= 0
    h = 1e-6  # dW/dgamma = torque: central differences (W is C2)
    np.testing.assert_allclose((c.energy(g + h) - c.energy(g - h)) / (2 * h), t,
                               rtol=0, atol=1e-9)
    # common slope at 0: left and right difference quotients of the torque agree
    h = 1e-8
    right, left = c.torque(h) / h, -c.torque(-h) / h
    assert right == pytest.approx(left, rel=1e-6)
    # linear beyond the last point
    tail = c.torque(np.radians([62.0, 66.0, 70.0]))
    assert tail[2] - tail[1] == pytest.approx(tail[1] - tail[0], rel=1e-12)
    # the UFL forms: same values, symbolic dW/dgamma = torque, data and slope at 0
    probes = np.concatenate([g[::60], x, -x, [0.0, 1e-8, -1e-8]])
    for gam in probes:
        r = probe(gamma=gam)
        assert r["torque"] == pytest.approx(c.torque(gam), rel=1e-13, abs=1e-16)
        assert r["energy"] == pytest.approx(c.energy(gam), rel=1e-13, abs=1e-18)
        assert r["dwdg"] == pytest.approx(r["torque"], rel=1e-14, abs=1e-18)
    for gam in (-55.5 * DEG, -12.0 * DEG, 33.0 * DEG, 68.0 * DEG):
        h = 1e-6
        fd = (probe(gamma=gam + h)["energy"] - probe(gamma=gam - h)["energy"]) / (2 * h)
        assert fd == pytest.approx(probe(gamma=gam)["torque"], rel=1e-8)
    assert probe(gamma=1e-8)["torque"] / 1e-8 == pytest.approx(
        -probe(gamma=-1e-8)["torque"] / 1e-8, rel=1e-6)


@pytest.mark.parametrize("lam", [1.01, 0.99])
def test_fibre_tension_and_compression(probe, fabric, lam):
    """Uniaxial stretch along fibre 1: P_membrane = E_eff (lam - 1) a1 (x) a1, E_eff = E or r E.

    dlam/dF = F a1 (x) a1 / lam = a1 (x) a1 since F a1 = lam a1; fibre 2 (orthogonal) and
    the shear angle are unchanged, so the shear term contributes nothing.
    """
    a1 = fabric.fibre_directions[0]
    r = probe(np.eye(3) + (lam - 1) * np.outer(a1, a1))
    e = fabric.fibre_modulus * (1.0 if lam > 1 else fabric.compression_ratio)
    assert r["lam1"] == pytest.approx(lam, rel=1e-14) and abs(r["gamma"]) < 1e-14
    # beyond the toe (width d), tension is shifted by (1 - r) d / 2; compression is not
    d, ratio = fabric.toe_strain, fabric.compression_ratio
    shift = (1 - ratio) * d / 2 if lam > 1 else 0.0
    stress = e * (lam - 1) - fabric.fibre_modulus * shift
    np.testing.assert_allclose(r["Pmem"], stress * np.outer(a1, a1), rtol=0,
                               atol=1e-10 * abs(stress))
    energy = 0.5 * e * (lam - 1) ** 2
    if lam > 1:
        energy -= 0.5 * fabric.fibre_modulus * (1 - ratio) * (d * (lam - 1) - 0.3 * d**2)
    assert r["mem"] == pytest.approx(energy, rel=1e-10)
    # the matrix (K + 4 mu / 3 = 1 MPa here) adds 3% to the fibre in compression, 3e-5 in tension
    tol = 0.05 if lam < 1 else 1e-4
    assert abs(a1 @ r["P"] @ a1 / (a1 @ r["Pmem"] @ a1) - 1) < tol


def general_F(fabric):
    """Sheared by 25 deg, fibres stretched +0.3% / -0.4%, thickened, transversely sheared."""
    a1, a2 = fabric.fibre_directions
    F = picture_frame(fabric, 25 * DEG, 1.08)
    F = F @ (np.eye(3) + 0.003 * np.outer(a1, a1) - 0.004 * np.outer(a2, a2))
    F[0, 2], F[1, 2] = 0.02, -0.01
    return F


def test_objectivity(probe, fabric):
    F = general_F(fabric)
    r0 = probe(F)
    for axis, angle in (((1, 2, 3), 0.7), ((0, 0, 1), -2.0), ((1, -1, 0.2), 3.0)):
        r = probe(rotation(axis, angle) @ F)
        for key in ("psi", "mem", "mat", "gamma", "lam1", "lam2"):
            assert r[key] == pytest.approx(r0[key], rel=1e-12, abs=1e-15), key


def taylor_slopes(probe, F, dF, hs):
    r0 = probe(F, dF)
    r1, r2 = [], []
    for h in hs:
        r = probe(F + h * dF)
        r1.append(abs(r["psi"] - r0["psi"] - h * np.sum(r0["P"] * dF)))
        r2.append(np.linalg.norm(r["P"] - r0["P"] - h * r0["AdF"]))
    return np.log2(np.array(r1[:-1]) / r1[1:]), np.log2(np.array(r2[:-1]) / r2[1:])


@pytest.mark.parametrize("modulus", [35000.0, 1.0])
def test_taylor_stress_and_tangent(probe, fabric, modulus):
    """Remainders of psi and P are O(h^2); fibre modulus 1 MPa lets the shear term show."""
    p = probe if modulus == fabric.fibre_modulus else Probe(NonCrimpFabric(fibre_modulus=modulus))
    dF = np.random.default_rng(7).uniform(-1, 1, (3, 3))
    hs = 1e-3 / 2.0 ** np.arange(5)
    s1, s2 = taylor_slopes(p, general_F(fabric), dF / np.linalg.norm(dF), hs)
    np.testing.assert_allclose(s1, 2.0, atol=0.05)
    np.testing.assert_allclose(s2, 2.0, atol=0.05)


def test_assembled_energy_matches(probe, fabric):
    fem = probe.fem
    F = general_F(fabric)
    dx = ufl.Measure("dx", domain=probe.msh, metadata={"quadrature_degree": 1})
    form = fem.form(probe.psi * dx)
    probe.Fc.value = F
    assert fem.assemble_scalar(form) == pytest.approx(probe(F)["psi"], rel=1e-13)


HEADER = ",".join(COLUMNS)


def _csv(tmp_path, body, header=HEADER):
    p = tmp_path / "curve.csv"
    p.write_text(f"# a comment\n{header}\n{body}")
    return p


def test_csv_reading_and_errors(tmp_path):
    rows = "\n".join(f"{a},{p},{n}" for a, p, n in zip(ANGLES, POS, NEG, strict=True))
    c = ShearCurve.from_csv(_csv(tmp_path, rows))
    assert c.force_negative == NEG
    swapped = ",".join([COLUMNS[0], COLUMNS[2], COLUMNS[1]])
    assert ShearCurve.from_csv(_csv(tmp_path, rows, swapped)).force_negative == POS
    with pytest.raises(InputError, match="force_positive") as e:
        ShearCurve.from_csv(_csv(tmp_path, rows, "shear_deg,force_positive,force_negative"))
    assert e.value.field == "shear.path"
    bad = rows.replace("30.0,0.08", "20.0,0.08")  # line 5 of the file (comment, header, 10, 20)
    with pytest.raises(InputError, match="line 5") as e:
        ShearCurve.from_csv(_csv(tmp_path, bad))
    assert e.value.field == "shear.shear_deg"
    with pytest.raises(InputError, match="not numeric") as e:
        ShearCurve.from_csv(_csv(tmp_path, rows.replace("0.045", "x")))
    with pytest.raises(InputError, match="not found"):
        ShearCurve.from_csv(tmp_path / "missing.csv")


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"shear_deg": (10, 10, 20)}, "shear.shear_deg"),
    ({"shear_deg": (20, 10, 30)}, "shear.shear_deg"),
    ({"shear_deg": (0, 10, 20)}, "shear.shear_deg"),
    ({"shear_deg": (10, 20)}, "shear.shear_deg"),
    ({"force_positive": (0.1, -0.2, 0.3)}, "shear.force_positive"),
    ({"force_negative": (0.1, 0.05, 0.3)}, "shear.force_negative"),
    ({"force_negative": (0.1, math.nan, 0.3)}, "shear.force_negative"),
])
def test_curve_rejects_bad_data(kwargs, field):
    args = {"shear_deg": (10, 20, 30), "force_positive": (0.1, 0.2, 0.3),
            "force_negative": (0.1, 0.2, 0.3)} | kwargs
    with pytest.raises(InputError) as e:
        ShearCurve(**args)
    assert e.value.field == field


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"thickness": -0.4}, "fabric.thickness"),
    ({"fibre_modulus": 0.0}, "fabric.fibre_modulus"),
    ({"compression_ratio": 0.0}, "fabric.compression_ratio"),
    ({"compression_ratio": 1.5}, "fabric.compression_ratio"),
    ({"fibre_angles_deg": (45.0, 225.0)}, "fabric.fibre_angles_deg"),
    ({"fibre_angles_deg": (30.0,)}, "fabric.fibre_angles_deg"),
    ({"bulk_modulus": -1.0}, "fabric.bulk_modulus"),
    ({"shear_modulus": 0.0}, "fabric.shear_modulus"),
    ({"transverse_shear_modulus": -1.0}, "fabric.transverse_shear_modulus"),
    ({"critical_angles_deg": (-42.0, 50.0)}, "fabric.critical_angles_deg"),
    ({"shear": "estimate"}, "fabric.shear"),
])
def test_fabric_rejects_bad_input(kwargs, field):
    with pytest.raises(InputError) as e:
        NonCrimpFabric(**kwargs)
    assert e.value.field == field
