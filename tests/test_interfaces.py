"""Several bodies: skin-core interfaces (Jacobian, sled, bending bounds, hemisphere)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from helpers import block_taylor, block_vector, run_mpi

from forming.case import load_case, parse_params, run_case
from forming.model import Model


@pytest.mark.parametrize("friction", [0.0, 0.52])
def test_interface_jacobian_taylor(friction):
    """Slopes 1 and 2 of the Taylor remainders of the coupled residual of a skin on a
    core (frictionless or Coulomb with elastic slip) over a bonded skin, at a state with
    every top-interface node in contact and, with friction, some sliding and some
    sticking.

    The state: the top skin pressed 5 um into the core (five times the random part of
    the state, so no node opens) and its interface nodes moved along x by
    2.4 s_el (x / L)^2 (s_el = 0.005 x 25 mm, the elastic slip): nodes at x = 0 and
    x = L/2 stick (slip 0 and 0.6 s_el), those at x = L slide (2.4 s_el), all away from
    the stick-slip switch by more than the Taylor steps (4e-5 mm). Asserted from public
    outputs: the nodal slips (``InterfaceTerm.slip``) of both kinds, a positive normal
    force and, with friction, a shear force above zero and below mu x the normal force
    (sticking nodes carry less than the cone).

    A second-remainder slope of 1 would mean a coupling block of the Jacobian (skin-core
    or core-skin), the derivative of the rotating contact normal, or the stick or the
    slip branch of the friction law is not differentiated consistently.
    """
    mod = load_case("skin_sled")
    p = parse_params(mod.Params, [f"friction={friction}", "element=25"])
    model = Model(mod.build(p).scene)
    top = next(itf for itf in model.interfaces if itf.name == "interface_top")
    s_el = 0.005 * top.edge

    def skin(x):
        return np.column_stack([2.4 * s_el * (x[:, 0] / p.length) ** 2,
                                np.zeros(len(x)), np.full(len(x), -5e-3)])

    s1, s2 = block_taylor(model, t=0.0, base=block_vector(model, {"skin_top": skin}))
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(s2 > 1.9), s2
    # the state the slopes were taken at
    assert top.penetration() > 2e-3
    normal = top.normal_force()
    assert normal > 0.0
    if friction > 0.0:
        assert top.elastic_slip == pytest.approx(s_el)
        slip = np.linalg.norm(top.slip()[0], axis=1)
        assert np.count_nonzero(slip > 1.5 * s_el) >= 3, slip / s_el  # sliding
        assert np.count_nonzero(slip < 0.8 * s_el) >= 3, slip / s_el  # sticking
        shear = np.linalg.norm(top.shear_force())
        assert 0.0 < shear < friction * normal, (shear, normal)


def _rows(path):
    with open(path / "history.csv") as f:
        return list(csv.DictReader(f))


def test_skin_sled_friction_ratio(tmp_path):
    """A fabric dragged over the core under 2 kPa: drag / normal force within 1% of the
    fabric-core coefficient 0.52; the skin slides, the bonded bottom skin does not, and
    the skin does not sink into the core beyond the tolerance."""
    s = run_case("skin_sled", tmp_path, [])
    m = s["metrics"]
    assert s["status"] == "completed"
    assert m["friction_ratio"] == pytest.approx(0.52, rel=0.01)
    assert m["friction_ratio_applied_load"] == pytest.approx(0.52, rel=0.01)
    assert m["slip_mm"] > 1.9  # of 2 mm pulled
    assert m["bonded_slip_mm"] < 1e-3
    assert m["penetration_mm"] < 0.01 * 0.4


@pytest.mark.mpi
def test_skin_sled_two_ranks_matches_serial(tmp_path):
    """The three-body sled on 2 ranks gives the serial ratio to 1e-8."""
    serial = run_case("skin_sled", tmp_path / "serial", [])
    proc = run_mpi(["cases/skin_sled.py", "--out", str(tmp_path / "mpi")])
    assert proc.returncode == 0, proc.stderr[-3000:]
    par = json.loads((tmp_path / "mpi" / "summary.json").read_text())
    assert par["ranks"] == 2
    assert par["metrics"]["friction_ratio"] == pytest.approx(
        serial["metrics"]["friction_ratio"], rel=1e-8)


def test_the_sandwich_jacobian_without_its_zeros_gives_the_same_answer(tmp_path):
    """The three-body sled (skins on a core, small-sliding frictional interfaces) with the
    several-body Jacobian's exact zeros left out (the default below 20,000 unknowns) and
    kept (``newton.zeros=keep``): the same load steps and Newton iterations, and the friction
    ratio within 1e-9 (round-off of the LU on another pattern), while the matrix stores
    fewer entries (an interface's facet forms fill element matrices over both cells, most
    of them exact zeros under the vertex rule: measured 3.3 times fewer). A failure means
    a dropped entry was not zero, or an entry that became non-zero later was lost, or the
    full pattern misses an entry (PETSc then allocates inside the assembly).
    """
    drop = run_case("skin_sled", tmp_path / "drop", [])
    keep = run_case("skin_sled", tmp_path / "keep", ["newton.zeros=keep"])
    for s in (drop, keep):
        assert s["status"] == "completed", s["reason"]
    td, tk = drop["timing"], keep["timing"]
    assert (td["steps"], td["newton_iterations"]) == (tk["steps"], tk["newton_iterations"])
    assert drop["metrics"]["friction_ratio"] == pytest.approx(
        keep["metrics"]["friction_ratio"], rel=1e-9)
    assert td["jacobian_nonzeros"] < 0.8 * tk["jacobian_nonzeros"]
    assert td["jacobian_zeros"] == "drop" and tk["jacobian_zeros"] == "keep"
    assert tk["jacobian_mallocs"] == 0  # the forms' full pattern holds every entry


def test_sandwich_bending_frictional_softer_than_bonded(tmp_path):
    """Three-point bending, coarse strip, bonded against frictional skins (both with the
    case's elastic-slip stick law on the rollers, so only the interface differs).

    The frictional sandwich is less than half as stiff as the bonded one: composite
    action needs a skin force M / d = P L / (4 d) = 3.8 P at mid-span (span 160 mm,
    skin centres 10.4 mm apart), while friction can pass into a skin at most mu times
    the interface's normal force, about the roller force P: 0.52 P (measured ratio
    0.10). Its skins slip at the strip's ends (more than 0.1 mm; measured 0.93 mm), the
    bonded ones do not (below 1 um).

    The frictionless variant is not compared: the case gives it the augmented stick law
    on the rollers (its skins have an almost free trellis mode otherwise), so its
    stiffness would mix two effects (frictional and frictionless differ by 5%).
    """
    common = ["element=10", "core_layers=2", "deflection=8", "max_step=0.1"]
    m = {}
    for kind in ("bonded", "frictional"):
        s = run_case("sandwich_bending", tmp_path / kind, common + [f"interface={kind}"])
        assert s["status"] == "completed", (kind, s["reason"])
        m[kind] = s["metrics"]
    k = {kind: m[kind]["stiffness_N_per_mm"] for kind in m}
    assert 0.0 < k["frictional"] < 0.5 * k["bonded"], k
    assert m["bonded"]["end_slip_mm"] < 1e-3
    assert m["frictional"]["end_slip_mm"] > 0.1


def test_hemisphere_skins_with_holder_full_stroke(tmp_path):
    """The sandwich (core and two fabric skins) formed over the full 50 mm stroke with the
    blank holder clamping the flange, coarse mesh (issue #4, stability).

    Every interface node under the holder starts at zero pressure, the skins are pushed
    into compression over the die radius, and they slide many millimetres over the core:
    a stall, an inverted element or a skin sinking into the core fails this test.
    """
    s = run_case("hemisphere", tmp_path, ["skins=true", "skin_contact=small", "blank_holder=true",
                                          "cells=8,8,2"])
    assert s["status"] == "completed", s["reason"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    m = s["metrics"]
    assert np.all(h["min_det_F"] > 0.0)
    assert m["max_penetration_mm"] <= m["penetration_tolerance_mm"]
    for side in ("bottom", "top"):
        # interface tolerance: 1% of the 0.4 mm skin
        assert np.all(h[f"penetration_interface_{side}_mm"] <= 0.004 + 1e-12)
    assert m["edge_lift_max_mm"] < 0.1  # the holder keeps the flange down
    assert m["skin_core_slip_max_mm"] > 1.0  # the skins slide over the core
    assert m["shear_min_deg"] < -5.0 < 5.0 < m["shear_max_deg"]
    section = np.pi * 50.0**2
    assert 0.01 * 0.25 * section < m["punch_force_max_N"] < 4.0 * section


def test_bonded_quadratic_faces_are_tied_at_every_node(tmp_path):
    """A 10 x 10 x 20 mm column of three quadratic bodies of one elastic material (a core
    between two skins as thick as half the core), tied by bonded interfaces, symmetry
    planes at x = 0 and y = 0, its top pushed down by 0.01 mm: uniaxial stress, so the
    top force is E A delta / H (measured 1.00075 of it: the finite strain of the
    material's measure).

    Quadratic faces tied only at their corners (the vertex rule) leave their other nodes
    free, and the interface's nodal forces are not the consistent ones: the column then
    carried 0.176 of the force. A failure means the interface's nodal rule or its
    multipliers' degree no longer matches the bodies' (forming/contact/terms.py
    ``nodal_rule``), which the meso model's bonded dummy flanges rely on.
    """
    from forming.job import Job
    from forming.materials.elasticity import IsotropicElasticity
    from forming.materials.solids import ElasticSolid
    from forming.outline import Outline
    from forming.run import simulate
    from forming.sandwich import sandwich_blank
    from forming.scene import Body, Displacement, Interface, Linear, Scene
    from forming.solver.stepping import StepControl

    E, delta, side, height = 100.0, 0.01, 10.0, 20.0
    mesh = sandwich_blank(Outline.rectangle(side, side), core_thickness=10.0,
                          skin_thickness=5.0, plies=1, element_size=5.0, core_layers=2)
    names = ("core", "skin_bottom", "skin_top")
    held = [Displacement("skin_bottom", "bottom", z=0.0, reaction=False),
            Displacement("skin_top", "top", z=Linear(-delta))]
    for b in names:
        held += [Displacement(b, f"{b}_edge_xmin", x=0.0, reaction=False),
                 Displacement(b, f"{b}_edge_ymin", y=0.0, reaction=False)]
    material = ElasticSolid(IsotropicElasticity(E, 0.3))
    scene = Scene(
        name="column", mesh=mesh,
        bodies=tuple(Body(b, material, region=b, degree=2) for b in names),
        displacements=tuple(held),
        interfaces=tuple(Interface(f"interface_{s}", "core", f"skin_{s}", kind="bonded",
                                   tolerance=1e-7) for s in ("bottom", "top")))
    s = simulate(Job(scene=scene, steps=StepControl(initial=1.0, max=1.0)), tmp_path,
                 "column", {})
    assert s["status"] == "completed", s.get("reason")
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    force = -h["reaction_skin_top_top_z_N"][-1]
    assert force == pytest.approx(E * side**2 * delta / height, rel=2e-3)
