"""Bad input gets a clear error naming the offending field."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import pytest

from forming.case import find_case, parse_params
from forming.errors import InputError
from forming.materials.curves import CompressionCurve
from forming.materials.elasticity import IsotropicElasticity, TransverselyIsotropicElasticity
from forming.materials.library import honeycomb_core
from forming.mesh import box, from_file
from forming.scene import Linear, Table
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl


def test_missing_curve_file(tmp_path):
    with pytest.raises(InputError, match=r"curve.path: file not found: .*nope.csv"):
        honeycomb_core(curve=tmp_path / "nope.csv")


def test_non_monotonic_curve(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("strain,stress\n0,0\n0.02,0.3\n0.015,0.35\n0.5,0.3\n")
    with pytest.raises(InputError, match=r"curve.strain: is not monotonic: point 2"):
        honeycomb_core(curve=p)


def test_malformed_curve_row(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("strain,stress\n0,0\n0.02,abc\n")
    with pytest.raises(InputError, match=r"curve.path: .*row 2 is not numeric"):
        CompressionCurve.from_csv(p)


def test_curve_inconsistent_with_modulus():
    with pytest.raises(InputError, match=r"curve: point 1 .* above the elastic line"):
        honeycomb_core(E_through=12.0)


def test_negative_moduli():
    with pytest.raises(InputError, match=r"elasticity.E_through: must be a positive number"):
        honeycomb_core(E_through=-1.0)
    with pytest.raises(InputError, match=r"elasticity.E: must be a positive number, got -5"):
        IsotropicElasticity(-5.0)
    with pytest.raises(InputError, match=r"elasticity.G_through"):
        TransverselyIsotropicElasticity(15.0, 0.2, 0.0)


def test_unknown_core_parameter_and_strain_measure():
    with pytest.raises(InputError, match=r"core.E_plane: unknown core parameter"):
        honeycomb_core(E_plane=1.0)
    with pytest.raises(InputError, match=r"material.strain_measure: must be one of"):
        honeycomb_core(strain_measure="green")


def test_foam_parameters():
    with pytest.raises(InputError, match=r"material.k: must lie in \(0, 3\)"):
        honeycomb_core(k=3.5)


def test_missing_mesh_file(tmp_path):
    with pytest.raises(InputError, match=r"mesh.path: file not found"):
        from_file(tmp_path / "missing.msh")


def test_bad_box():
    with pytest.raises(InputError, match=r"mesh.size: edge lengths must be three positive"):
        box((10.0, -1.0, 2.0), (1, 1, 1))


def test_load_paths_and_steps():
    with pytest.raises(InputError, match=r"path.t: must increase strictly"):
        Table((0.0, 0.6, 0.5, 1.0), (0, 1, 2, 3))
    with pytest.raises(InputError, match=r"path.total"):
        Linear(float("nan"))
    with pytest.raises(InputError, match=r"steps.min"):
        StepControl(min=0.0)
    with pytest.raises(InputError, match=r"solver.linear_solver"):
        NewtonOptions(linear_solver="hypre")


@dataclass(frozen=True)
class _P:
    strain: float = 0.9
    cells: tuple[int, ...] = (1, 1, 1)
    flag: bool = False
    kind: Literal["a", "b"] = "a"
    curve: str | None = None


def test_set_parsing():
    p = parse_params(_P, ["strain=0.5", "cells=2,3,4", "flag=true", "kind=b", "curve=x.csv"])
    assert p == _P(0.5, (2, 3, 4), True, "b", "x.csv")
    with pytest.raises(InputError, match=r"--set strian: unknown parameter; known: "):
        parse_params(_P, ["strian=0.5"])
    with pytest.raises(InputError, match=r"--set strain: must be float"):
        parse_params(_P, ["strain=lots"])
    with pytest.raises(InputError, match=r"--set kind: must be one of"):
        parse_params(_P, ["kind=c"])
    with pytest.raises(InputError, match=r"--set: expected key=value"):
        parse_params(_P, ["strain"])


def test_unknown_case():
    with pytest.raises(InputError, match=r"unknown case 'hemisphear'; known: .*core_compression"):
        find_case("hemisphear")


def test_case_parameters_out_of_range(tmp_path):
    """Case parameters outside their physical range name the parameter."""
    from forming.case import run_case

    for case, assignment, field in (("core_crushing", "gap=-1", "gap"),
                                    ("picture_frame", "shear_max_deg=85", "shear_max_deg"),
                                    ("bias_extension", "aspect=1.5", "aspect"),
                                    ("demonstrator", "tool_penalty_scale=0",
                                     "tool_penalty_scale"),
                                    ("demonstrator", "skin_elastic_slip=-1e-3",
                                     "skin_elastic_slip")):
        with pytest.raises(InputError, match=rf"^--set {field}: "):
            run_case(case, tmp_path / case, [assignment])
    from forming.scene_contact import Contact

    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(InputError, match=r"^contact.penalty_scale: "):
            Contact("skin", "top", "tool", penalty_scale=bad)
    from forming.scene_contact import Sliding

    for bad in (0.0, -1.0, float("inf")):
        with pytest.raises(InputError, match=r"^sliding.elastic_slip: "):
            Sliding("s", "core", "core_top", "skin", "skin_bottom", elastic_slip=bad)
    with pytest.raises(InputError, match=r"newton.force_rtol|solver.force_rtol"):
        NewtonOptions(force_rtol=-1.0)
    with pytest.raises(InputError, match=r"solver.blr_tolerance"):
        NewtonOptions(linear_solver="mumps_blr", blr_tolerance=0.0)
    with pytest.raises(InputError, match=r"^newton.lu_precision: .*'half'"):
        NewtonOptions(lu_precision="half")


def test_affine_displacement_components():
    import numpy as np

    from forming.scene import AffineDisplacement

    with pytest.raises(InputError, match=r"displacement\[xmin\].components"):
        AffineDisplacement("ply", "xmin", lambda t: np.zeros((3, 3)), components=(3,))
    with pytest.raises(InputError, match=r"displacement\[xmin\].gradient"):
        AffineDisplacement("ply", "xmin", lambda t: np.zeros(3))
