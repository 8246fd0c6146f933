"""Fabric skins in explicit runs: the fibres' damping and the energy ledger of damping."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem

from forming.case import run_case
from forming.materials.fabric import NonCrimpFabric
from forming.mesh import box
from forming.model import Model
from forming.scene import Body, Displacement, Scene
from forming.vectors import assembled

SIDE, T = 30.0, 0.4  # ply side and thickness [mm]


@pytest.mark.parametrize("strain", [0.01, 5e-4, -0.01])
def test_fibre_viscosity_is_beta_times_tangent_times_stretch_rate(strain):
    """A ply with its fibres along x and y, stretched uniformly along x (stretch 1 + e)
    at the rate r: the damping forces on the face x = L sum to ``beta E_t r T L``, with
    ``E_t`` the fibre's tangent modulus: E beyond the toe (e = 0.01), ``E (c + (1 - c)
    / 2)`` halfway through it (e = toe / 2, the smoothstep's midpoint; c the compression
    ratio), ``c E`` in compression (e = -0.01). The fibres along y do not stretch and
    add nothing across the face.

    A mismatch would mean the damping is not the stiffness-proportional viscosity of
    docs/theory.md (the highest mode would not be damped at the stated ratio).
    """
    fabric = NonCrimpFabric(fibre_angles_deg=(0.0, 90.0))
    scene = Scene("ply", box((SIDE, SIDE, T), (3, 3, 1)), (Body("ply", fabric),),
                  displacements=(Displacement("ply", "xmin", x=0.0),))
    body = Model(scene).body
    x = body.V.tabulate_dof_coordinates()
    body.u.x.array[:] = np.column_stack([strain * x[:, 0], 0 * x[:, 0], 0 * x[:, 0]]).ravel()
    rate, beta_s = 3.0, 2e-6  # [1/s], [s]
    v = fem.Function(body.V)
    v.x.array[:] = np.column_stack([rate * x[:, 0], 0 * x[:, 0], 0 * x[:, 0]]).ravel()
    beta = fem.Constant(body.mesh, beta_s)
    f = assembled(fem.form(body.viscous_residual(v, beta, ufl.TestFunction(body.V))))
    on_face = np.isclose(x[:, 0], SIDE)
    force = f.reshape(-1, 3)[on_face, 0].sum()
    c, toe = fabric.compression_ratio, fabric.toe_strain
    tangent = {0.01: 1.0, 5e-4: c + (1 - c) * 0.5, -0.01: c}[strain] * fabric.fibre_modulus
    if strain == 5e-4:
        assert strain == toe / 2
    assert force == pytest.approx(beta_s * tangent * rate * T * SIDE, rel=1e-10)
    assert abs(f.reshape(-1, 3)[on_face, 1].sum()) < 1e-12 * abs(force)


def _frame(tmp_path, *items: str) -> dict:
    """The explicit frame with constant-rate legs over 0.05 s: its reversal at +55 deg
    is a jolt (the case's default legs start and stop at rest, over 0.4 s)."""
    return run_case("picture_frame", tmp_path, ["solver=explicit", "cells=4,4,1",
                                                "programme=linear",
                                                "explicit.loading_time=0.05", *items])


def test_explicit_picture_frame_with_damped_fibres(tmp_path):
    """The picture frame explicitly (4 x 4 ply, 0.05 s for the whole shear cycle, legs at
    constant rate): the frame reverses at +55 deg, and the jolt sets the taut fibres
    ringing. With the default fibre damping (6% of critical at the highest mode) the run
    balances its energy within 1e-3 and reproduces the input curve within 2% on the
    positive branch and 8% on the negative one (measured 0.9% and 5.6%; the rest is
    inertia of the frame's reversals, which mass damping removes: the test after the
    next). The undamped contrast, which shows the damping is needed, is the next test
    (slow suite).

    A failure means the fibre damping or its time step changed.
    """
    damped = _frame(tmp_path)
    assert damped["status"] == "completed", damped["reason"]
    m = damped["metrics"]
    assert m["energy_balance_error_rel"] < 1e-3
    assert m["shear_curve_rmse_rel_positive"] < 0.02
    assert m["shear_curve_rmse_rel_negative"] < 0.08


@pytest.mark.slow  # two frame runs (30 s); the damped one is in CI (the test above)
def test_explicit_picture_frame_needs_its_fibres_damped(tmp_path):
    """The explicit frame of the test above, undamped: the
    ringing feeds on itself through the fibres' toe (a thousandfold stiffening within
    1e-3 strain): 5.6% of the external work is created from nothing and the negative
    branch is off by 32% RMS (measured; on the default 8 x 8 ply the run went unstable
    at load 0.81). The step shrinks by ``sqrt(1 + z^2) - z`` for the damping ratio z. The
    undamped contrast takes the stable-step bound at every output interval
    (``explicit.bound_every=0``), as when it was measured; with the default (every 0.1
    of the load, where the step only shrinks in between) the same undamped run created
    0.8% of the external work and was off by 14% on the negative branch, against 8.5%
    and 35% (measured at 4e3ea81): how fast the ringing grows follows the step's path.

    How much energy the undamped ringing creates depends on the machine's round-off: the
    same run created 5.6% of the external work on an AMD EPYC and 1.87% on an Intel Xeon
    (2026-11-27; negative branch off by 32% and 33%), so the contrast asks for ten times
    the damped run's bound (1%; the damped run: 0.014%), not a fixed 2%.

    A failure means the toe no longer rings (then the damping may be moot), or the damped
    step is no longer the undamped one times ``sqrt(1 + z^2) - z``.
    """
    damped = _frame(tmp_path / "damped")
    assert damped["status"] == "completed", damped["reason"]
    bare = _frame(tmp_path / "bare", "explicit.fibre_damping=0", "explicit.bound_every=0")
    b = bare["metrics"]
    assert bare["status"] == "failed" or (b["energy_balance_error_rel"] > 0.01
                                          and b["shear_curve_rmse_rel_negative"] > 0.2)
    dt = [np.genfromtxt(p / "history.csv", delimiter=",", names=True)["time_step_s"][0]
          for p in (tmp_path / "damped", tmp_path / "bare")]
    assert dt[0] / dt[1] == pytest.approx(math.sqrt(1 + 0.06**2) - 0.06, rel=1e-9)


def test_mass_damping_is_booked_once(tmp_path):
    """Mass-proportional damping (2000 1/s) on the explicit picture frame dissipates
    most of the external work (85%, measured); the ledger balances within 1e-3 of the
    external work, and the frame force then follows the input curve within 1% RMS.

    Until this test the damping's work was added to the external work as well as to
    the damping energy: the balance was off by the whole damping energy (0.46 of the inflated
    external work, measured). A failure
    means a damping force whose work is booked twice, or not at all.
    """
    s = _frame(tmp_path, "explicit.damping=2000")
    assert s["status"] == "completed", s["reason"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    assert h["energy_damping_Nmm"][-1] > 0.5 * h["work_external_Nmm"][-1]
    assert s["metrics"]["energy_balance_error_rel"] < 1e-3
    assert s["metrics"]["shear_curve_rmse_rel"] < 0.01


def test_contact_damping_adds_a_viscous_pressure_only_while_touching():
    """A rigid plane z <= 0 and four nodes, node by node (the explicit tool contact):
    the pressure is ``max(-eps g - c dg/dt, 0)``: a penetrating node approaching at 2
    mm/s carries the penalty's pressure plus ``2 c``; one separating fast enough carries
    none (the damper never pulls); a node above the plane carries nothing however fast
    it approaches (no pressure before contact); without damping the penalty's alone.
    A failure means the damping acts where it must not (tension, or at a distance).
    """
    from forming.contact.nodal import NodalContact
    from forming.contact.shapes import Plane

    eps, c = 10.0, 0.5  # [N/mm^3], [MPa s/mm]
    coords = np.array([[0.0, 0, -0.01], [1.0, 0, -0.01], [2.0, 0, -0.01], [3.0, 0, 0.01]])
    contact = NodalContact(Plane(), np.arange(4), coords, np.ones(4), eps, 0.0)
    u = np.zeros(12)
    v = np.array([[0, 0, -2.0], [0, 0, 0.1], [0, 0, 1.0], [0, 0, -50.0]])  # dg/dt = v_z
    damped = -contact.residual(u, np.zeros(3), (np.full(4, c), v))[:, 2].copy()
    bare = -contact.residual(u, np.zeros(3))[:, 2].copy()
    assert bare == pytest.approx([0.1, 0.1, 0.1, 0.0])
    assert damped == pytest.approx([0.1 + 2 * c, 0.1 - 0.1 * c, 0.0, 0.0])


def test_explicit_large_slip_sled_keeps_most_of_its_friction(tmp_path):
    """The finite-sliding sled (fabric pulled 1 mm over the core under 2 kPa in 0.01 s,
    coarse skin; the weight on over the first tenth of the load, then the pull): the
    implicit run holds drag / load at mu = 0.52 at every sliding step. Explicitly the
    light skin nodes used to chatter on their penalty springs (the weight put on at once
    rang through the run), and a stick stiffness that followed their ringing pressure
    ratcheted the friction down: 0.016 of the load undamped, 0.20 with the contact
    damping (measured before the weight was ramped and the explicit pairs held a
    sticking node with the penalty). Now 0.465 (0.446 undamped). Asserted: the mean over
    the second half of the pull above 0.44 (mu within 15%). The rest of the gap is open
    (docs/validation.md). A failure means the explicit pairs lose their friction again.
    """
    sets = ["solver=explicit", "drag=1", "skin_cells=5", "explicit.loading_time=0.01"]
    s = run_case("sliding_sled", tmp_path, sets)
    assert s["status"] == "completed", s["reason"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    late = h["t"] > 0.55
    ratio = np.mean(np.abs(h["reaction_skin_skin_top_x_N"][late])) / (0.002 * 2400)
    assert ratio > 0.44, ratio


def test_explicit_small_sliding_sled_holds_the_friction_coefficient(tmp_path):
    """The skin sled with the small-sliding interface (weight on over the first 20% of
    the load, then 0.5 mm of drag, 0.01 s): while the skin slides, drag over the
    interface's normal force averages mu = 0.52 (implicit: 0.520 at every step). Before
    the interface's friction history was the elastic slip it was the traction: a node
    whose pressure dipped kept the lower traction and rebuilt it only by the stick
    spring times each increment's slip, so the drag fell steadily at a steady normal
    force (2.5 N to 0.04 N over 2 mm, measured); and the undamped interface's energy
    balance was off by 25%. Asserted: the mean ratio over the second half of the drag
    within 5% of 0.52, every row's normal force within 5% of the 5 N weight, the energy
    balance within 1e-4. A failure means the explicit friction of the small-sliding
    interface lost its history again, or its normal approach rings. (Measured
    2026-12-03: the ratio 0.3% below 0.52, the normal force within 0.008 N of 5 N, the
    balance 1.1e-5; at 0.02 s, 0.5%, 0.003 N and 2e-6, in about 1.5 times the time.)
    """
    sets = ["solver=explicit", "drag=0.5", "explicit.loading_time=0.01"]
    s = run_case("skin_sled", tmp_path, sets)
    assert s["status"] == "completed", s["reason"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    late = h["t"] >= 0.6
    normal = h["normal_force_interface_top_N"][late]
    ratio = np.mean(np.abs(h["reaction_skin_top_top_x_N"][late]) / normal)
    assert ratio == pytest.approx(0.52, rel=0.05)
    assert np.all(np.abs(normal - 5.0) < 0.25), normal
    assert s["metrics"]["energy_balance_error_rel"] < 1e-4


@pytest.mark.slow  # 53-64 s on a 2-core Intel Xeon (41,363 increments of 1.2e-6 s)
def test_explicit_sled_with_its_core_damped_keeps_the_coefficient_to_the_end(tmp_path):
    """The skin sled's full 2 mm pull in 0.05 s (an eighth of its default time) with its
    default damping of the held core (1e4 1/s on ``core`` alone): the drag over the
    normal force at the end is mu = 0.52 within 1%, as the implicit run (0.51996).

    Undamped (``--set explicit.damping=0``, same command) the core's shear mode rang as
    the skin stuck and slipped over it and the ratio ended at 0.16 (0.08 over 0.2 s):
    the friction force turned with the ringing core. The damping acts on the core
    only, whose quasi-static velocity is its own deformation's: its work stays below
    0.1% of the external work (0.004% at the default 0.4 s). A failure means the
    damping reaches the dragged skin (a biased drag) or no longer reaches the core (a
    lost coefficient).

    In ``scripts/dev.sh validate``, not the suite: it alone took 9% of the suite's
    wall on 2 workers. The suite keeps the damped sled at 0.02 s
    (:func:`test_explicit_small_sliding_sled_holds_the_friction_coefficient`, 5%).
    Half the drag in half the time ended at 0.514 (1.2% low), and mass scaling to
    2.4e-6 s at 0.446 (the damping is mass-proportional): neither keeps the 1%.
    """
    s = run_case("skin_sled", tmp_path, ["solver=explicit", "explicit.loading_time=0.05"])
    assert s["status"] == "completed", s["reason"]
    assert s["metrics"]["friction_ratio"] == pytest.approx(0.52, rel=0.01)
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    assert h["energy_damping_Nmm"][-1] < 1e-3 * h["work_external_Nmm"][-1]


def test_damped_bodies_must_name_bodies():
    """``explicit.damped_bodies`` naming no body of the scene is refused with the field
    and the scene's bodies named (a typo would otherwise leave every body undamped)."""
    from forming.errors import InputError
    from forming.materials.elasticity import IsotropicElasticity
    from forming.materials.solids import ElasticSolid
    from forming.solver.explicit import ExplicitSolver
    from forming.solver.options import ExplicitOptions

    mesh = box((1.0, 1.0, 1.0), (1, 1, 1))
    body = Body("block", ElasticSolid(IsotropicElasticity(10.0, 0.3), density=1e-9))
    scene = Scene(name="s", mesh=mesh, bodies=(body,),
                  displacements=(Displacement("block", "bottom", x=0.0, y=0.0, z=0.0),))
    with pytest.raises(InputError, match=r"explicit.damped_bodies.*\['core'\].*block"):
        ExplicitSolver(Model(scene, penalty_only=True),
                       ExplicitOptions(damping=100.0, damped_bodies=("core",)))
