"""The fabric skin as a body: Jacobian consistency and the virtual picture-frame test."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import body_taylor

from forming.case import run_case
from forming.materials.fabric import NonCrimpFabric
from forming.mesh import box
from forming.model import Model
from forming.scene import Body, Displacement, Scene


def _ply(n: int = 3) -> Model:
    mesh = box((30.0, 30.0, 0.4), (n, n, 1))
    scene = Scene("ply", mesh, (Body("ply", NonCrimpFabric()),),
                  displacements=(Displacement("ply", "xmin", x=0.0, y=0.0, z=0.0),))
    return Model(scene)


@pytest.mark.parametrize("shear", [0.35, -0.5])
def test_fabric_jacobian_taylor(shear):
    """Slopes 1 and 2 of the Taylor remainders of the fabric residual at a sheared,
    stretched, bent state (both shear branches, fibres in tension and compression).

    A slope of 1 for the second remainder would mean the Jacobian is not the derivative
    of the residual (e.g. a quadrature rule that differs between the two forms).
    """
    model = _ply()
    x = model.body.V.tabulate_dof_coordinates()
    u0 = np.zeros((x.shape[0], 3))
    u0[:, 0] = shear / 2 * x[:, 1] + 0.002 * x[:, 0]
    u0[:, 1] = shear / 2 * x[:, 0] - 0.001 * x[:, 1]
    u0[:, 2] = 0.002 * x[:, 0] ** 2 + 0.05 * x[:, 2]
    u0 = u0.ravel() + np.random.default_rng(5).normal(size=u0.size) * 1e-4
    s1, s2 = body_taylor(model, u0, seed=2)
    assert np.all(np.abs(s1 - 1.0) < 0.1)
    assert np.all(s2 > 1.9)


def test_picture_frame_reproduces_input_curve(tmp_path):
    """Frame force vs shear angle reproduces the picture-frame input within 2% (RMS and
    pointwise) from 5 to 55 deg in both directions; the ply shears uniformly (also in the
    cell field of final_shape.npz)."""
    s = run_case("picture_frame", tmp_path, [])
    m = s["metrics"]
    assert s["status"] == "completed"
    assert m["shear_max_deg"] == pytest.approx(55.0) and m["shear_min_deg"] == pytest.approx(-55.0)
    assert m["shear_curve_rmse_rel"] < 0.02
    assert m["shear_curve_max_err_rel_positive"] < 0.02
    assert m["shear_curve_max_err_rel_negative"] < 0.02
    assert m["shear_field_spread_deg"] < 1e-6
    with np.load(tmp_path / "final_shape.npz") as z:  # the cell field kept for scripts
        keys = [k for k in z.files if k.endswith("_cell_shear_angle_deg")]
        assert len(keys) == 1
        final = z[keys[0]]
        body = keys[0].removesuffix("_cell_shear_angle_deg")
        assert z[f"{body}_cell_X"].shape == (final.size, 3) and (z[f"{body}_cell_volume"] > 0).all()
    assert np.ptp(final) < 1e-6 and abs(final[0]) <= 55.0 + 1e-9
    assert (tmp_path / "picture_frame.png").is_file()
    assert (tmp_path / "shear_angle.bp").is_dir()


def test_bias_extension_follows_pin_jointed_kinematics(tmp_path, pictures):
    """1:2 specimen pulled until the kinematic central angle is 45 deg (below locking):
    the computed central shear angle stays within 2 deg of
    gamma = pi/2 - 2 acos((D + d) / (sqrt(2) D)) at every step; the clamped triangles stay
    unsheared (zone A). A larger error would mean fibre locking or fibre stretch."""
    s = run_case("bias_extension", tmp_path, ["element=3", "max_step=0.1"])
    m = s["metrics"]
    assert s["status"] == "completed"
    assert m["central_shear_error_deg"] < 2.0
    assert m["kinematic_shear_final_deg"] == pytest.approx(45.0)
    assert abs(m["shear_min_deg"]) < 1.0  # zone A at the clamps
    assert (tmp_path / "shear_angle.png").is_file()
