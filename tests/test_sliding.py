"""Finite sliding between bodies meshed apart (issue 17): the large-slip sled, Taylor."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from dolfinx.fem.petsc import assign
from helpers import history, run_mpi, solver_taylor

from forming.case import load_case, prepare_case, run_case
from forming.fields import FieldSeries
from forming.job import Job
from forming.scene import Scene
from forming.simulation import Simulation
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl

MU = 0.52  # fabric on core (paper)
AREA = 50.0 * 48.0  # fabric [mm^2]
SLED = load_case("sliding_sled")


def _same_histories(a, b, columns: tuple[str, ...], rtol: float = 1e-6) -> None:
    """Two runs' histories (folders ``a``, ``b``) have the same rows and equal columns."""
    h1 = history(a)
    h2 = history(b)
    assert len(h1) == len(h2)
    for col in columns:
        np.testing.assert_allclose(h2[col], h1[col], rtol=rtol,
                                   atol=rtol * np.abs(h1[col]).max())


def _sled(drag: float, overlap: float = 0.0, pressure: float = 0.002,
          skin: str = "fabric", transfer: str = "area") -> Scene:
    """The large-slip sled's scene (cases/sliding_sled.py), weight and pull together."""
    return SLED.scene(SLED.Params(drag=drag, overlap=overlap, pressure=pressure, skin=skin,
                                  transfer=transfer, weight_first=0.0))


def test_large_slip_sled_keeps_the_friction_ratio(tmp_path):
    """``cases/sliding_sled.py``: the fabric dragged 70 mm, 5.6 core element lengths, over
    the core on non-matching meshes: once sliding (after 3.5 mm), the drag over the
    normal force is mu = 0.52 within 1% at every step (measured within 2e-5) and the
    normal force is the 2 kPa load (1e-3); the interface penetrates less than its
    tolerance (1% of the fabric's thickness) at every step. The small-sliding interface
    cannot do this (its pairs stop facing each other after a fraction of an element); a
    ratio off by more means friction measured against the wrong master point after a
    node changed facet."""
    s = run_case("sliding_sled", tmp_path, [])
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    assert m["friction_ratio_min"] == pytest.approx(MU, rel=0.01)
    assert m["friction_ratio_max"] == pytest.approx(MU, rel=0.01)
    assert m["normal_force_N"] == pytest.approx(0.002 * AREA, rel=1e-3)
    assert m["drag_force_N"] == pytest.approx(MU * 0.002 * AREA, rel=0.01)
    assert m["penetration_max_mm"] < 0.01 * 0.4


def test_elastic_slip_sets_the_stick_compliance(tmp_path):
    """The implicit stick law's slip at the friction limit is ``elastic_slip`` times the
    shortest facet edge (4.8 mm: the fabric's 48 mm side over 10 elements), so the pull
    per unit friction ratio while the fabric sticks grows by ``(s1 - s2) h / mu`` from
    ``elastic_slip`` s2 = 5e-4 to s1 = 5e-3: 0.0415 mm. The structure's own compliance
    (skin and core in shear, about 0.011 mm) is the same in both runs and cancels.
    Measured 0.0419 (1.0%); tolerance 3%. A failure means the setting does not reach the
    stick law, or reaches it with another length scale (the sled on an elastic skin,
    pulled 0.012 mm after the weight: both runs stick over the first pull step)."""
    compliance = []
    for s_el in (0.005, 0.0005):
        out = tmp_path / f"s{s_el}"
        s = run_case("sliding_sled", out, ["drag=0.012", "skin=elastic", "max_step=0.1",
                                           f"elastic_slip={s_el}"])
        assert s["status"] == "completed", s["reason"]
        h = history(out)
        pull = 0.012 * np.clip((h["t"] - 0.1) / 0.9, 0.0, None)
        ratio = -h["sliding_skin_x_N"] / np.where(h["t"] > 0, h["sliding_skin_z_N"], 1.0)
        first, second = np.flatnonzero(h["t"] > 0.1 + 1e-9)[:2]  # the first two pull rows
        compliance.append((pull[second] - pull[first]) / (ratio[second] - ratio[first]))
    assert compliance[0] - compliance[1] == pytest.approx((0.005 - 0.0005) * 4.8 / MU,
                                                          rel=0.03)


@pytest.mark.mpi
def test_large_slip_sled_on_two_ranks_equals_serial(tmp_path):
    """The sled on two ranks (the master surface gathered on both, slave nodes split):
    the same forces as in serial (1e-6 relative), so nothing of the contact depends on
    the partition. Shorter pull (14 mm) to keep it quick."""
    serial = run_case("sliding_sled", tmp_path / "serial", ["drag=14"])
    proc = run_mpi(["cases/sliding_sled.py", "--out", str(tmp_path / "mpi"), "--set",
                    "drag=14"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    h1 = np.genfromtxt(tmp_path / "serial" / "history.csv", delimiter=",", names=True)
    h2 = np.genfromtxt(tmp_path / "mpi" / "history.csv", delimiter=",", names=True)
    assert serial["status"] == "completed"
    for col in ("sliding_skin_x_N", "sliding_skin_z_N", "reaction_skin_skin_top_x_N"):
        np.testing.assert_allclose(h2[col], h1[col], rtol=1e-6, atol=1e-9)
    _fields_equal_final_shape(tmp_path / "mpi", tmp_path / "serial")


def _fields_equal_final_shape(run: Path, reference: Path) -> None:
    """Each body's last displacement read back from a run's ParaView files equals the
    reference run's final shape (1e-6 of the largest displacement). On two ranks a body
    that one rank holds none of is written there as an empty block: a reader that
    tripped on it could not open the sled's skin."""
    with np.load(reference / "final_shape.npz") as z:
        shape = {k: z[k] for k in z.files}
    bodies = [k[:-2] for k in shape if k.endswith("_X") and f"{k[:-2]}_u" in shape]
    assert len(bodies) > 1
    for body in bodies:
        series = FieldSeries(run / f"displacement_{body}.bp")
        X, u = series.points(), series.values("u")
        order = np.lexsort(np.round(X, 6).T[::-1])
        ref = np.lexsort(np.round(shape[f"{body}_X"], 6).T[::-1])
        np.testing.assert_allclose(X[order], shape[f"{body}_X"][ref], atol=1e-9)
        scale = np.abs(shape[f"{body}_u"]).max()
        np.testing.assert_allclose(u[order], shape[f"{body}_u"][ref], atol=1e-6 * scale)


@pytest.mark.parametrize("sliding,transfer,stabilisation,smoothing", [
    (False, "area", 0.0, 0.0), (True, "area", 0.0, 0.0), (False, "point", 0.0, 0.0),
    (True, "point", 0.0, 0.0), (True, "area", 0.01, 0.0), (True, "point", 0.01, 0.0),
    (False, "area", 0.0, 1.0), (True, "area", 0.01, 1.0)])
def test_sliding_jacobian_taylor(tmp_path, sliding, transfer, stabilisation, smoothing):
    """Slopes 1 and 2 of the Taylor remainders of the whole sled (core, fabric and the
    sliding contact assembled outside the forms).

    Most slave nodes are pressed well away from zero pressure (a node at the kink of the
    pressure law would break the slopes there, whatever the Jacobian), and none sits on a
    facet edge. Without history: at rest, the fabric placed 0.02 mm into the core. With
    history: an elastic skin (E = 100 MPa: the fabric's first Newton iterate inverts
    elements under this load) under 50 kPa, after 4.2 mm of drag (sliding, the friction
    measured against the master points of the last step), the load then advanced by
    0.01. Both transfers of the slave's force to the master: at the closest point, and
    spread over the node's tributary area (the weights' motion with the node and the
    facet enters the Jacobian); with and without the stabilising spring (anchored at the
    master points of the step's start); with and without the smoothed pressure ramp (a
    parabola of the width of the tolerance's pressure). A second-remainder slope of 1
    means the pair Jacobians (central differences of the pair residual) miss a
    dependence, or land on the wrong global rows or columns."""
    scene = (_sled(70.0, pressure=0.05, skin="elastic", transfer=transfer) if sliding
             else _sled(0.0, overlap=0.02, transfer=transfer))
    scene = replace(scene, sliding=(replace(scene.sliding[0], stabilisation=stabilisation,
                                            smoothing=smoothing),))
    sim = Simulation(Job(scene, steps=StepControl(initial=0.02, max=0.02),
                         newton=NewtonOptions(line_search="basic")), tmp_path, "sled")
    sim.start()
    solver = sim.solver
    model = solver.model
    if sliding:
        while sim.t < 0.06 - 1e-9:  # (a step may be cut back and retried)
            sim.step()
        model.set_load(sim.t + 0.01)
    else:
        model.set_load(0.0)
    for bc, name in zip(model.dirichlet.bcs, model.dirichlet.bc_bodies, strict=True):
        bc.set(model.bodies[name].u.x.array)  # the base state meets the new load's values
    x = solver.unknowns()
    assign([b.u for b in solver.model.bodies.values()], x)
    s1, s2 = solver_taylor(solver, model, base=x.array.copy(), keep_prescribed=True)
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(s2 > 1.9), s2
    term = model.sliding[0]
    closed = term.p_new > 0.0
    assert closed.sum() >= 100, closed.sum()  # of 121 slave nodes
    if sliding:  # sliding on the friction cone, against history points
        assert np.all(term.hist[closed] >= 0)
        ratio = np.linalg.norm(term.shear[closed], axis=1) / (MU * term.p_new[closed])
        assert np.count_nonzero(ratio > 0.999) >= 30, ratio  # (48 measured)


@pytest.mark.parametrize("lower,upper", [(4, 5), (5, 4), (3, 7)])
def test_contact_patch_passes_with_area_transfer(tmp_path, lower, upper):
    """``cases/contact_patch.py`` (Taylor & Papadopoulos): a uniform 1 MPa passes across
    non-matching meshes (a finer slave on a coarser master, the reverse, and 3 against 7
    elements) with every slave node's pressure within 1% of it (measured 0.41%, 0.76%,
    0.40%), and the support carries the load (1e-5: the Newton tolerance). A larger
    deviation means the tributary-area weights no longer integrate the master's shape
    functions (the node to point transfer, the classic node-to-surface form, is 11% off
    on the first mesh)."""
    s = run_case("contact_patch", tmp_path, [f"lower_cells={lower}", f"upper_cells={upper}"])
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    assert m["pressure_deviation_max"] < 0.01
    assert m["support_force_N"] == pytest.approx(40.0 * 40.0, rel=1e-5)


def test_contact_patch_fails_with_point_transfer(tmp_path):
    """The classic node-to-surface form (``transfer=point``) fails the patch test on the
    4-against-5 mesh, as Taylor & Papadopoulos showed (measured 10.8% deviation): if it
    passed, the test above would not be testing what the area transfer adds."""
    s = run_case("contact_patch", tmp_path, ["transfer=point"])
    assert s["metrics"]["pressure_deviation_max"] > 0.05


def test_ironing_forces_are_smooth_and_frictional(tmp_path):
    """``cases/ironing.py`` on a coarse mesh (4 mm block elements, 16 die elements, 20 mm
    slide = 5 block elements): while sliding, the normal and tangential forces on the die
    depart from straight lines by less than 5% of their means (measured 0.23% and 1.3%),
    and tangential over normal is the friction coefficient 0.3 within 2% on average
    (measured 0.2948) and 3% at every step (measured 0.2913..0.2961). The ratio sits below
    0.3 by the die's curvature: the contact normals tilt, and friction lifts the die's rear
    half. Larger ripples mean the contact forces jump as nodes cross facet edges."""
    s = run_case("ironing", tmp_path, ["block_element=4", "die_cells=16", "slide=20",
                                       "max_step=0.02"])
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    assert m["normal_oscillation"] < 0.05
    assert m["tangential_oscillation"] < 0.05
    assert m["friction_ratio_mean"] == pytest.approx(0.3, rel=0.02)
    assert 0.97 * 0.3 < m["friction_ratio_min"] <= m["friction_ratio_max"] < 1.03 * 0.3
    assert m["penetration_max_mm"] < 0.01 * 40.0 / 16


@pytest.mark.mpi
def test_contact_patch_explicit_on_two_ranks(tmp_path):
    """The patch test with the explicit solver (pure penalty, 1 MPa ramped over 0.01 s,
    2299 increments), serial and on two ranks: quasi-static (kinetic energy 0.4% of the
    internal), energy balanced (2e-9 measured), every slave node's pressure within 1% of
    the applied one (0.41% measured, as implicit), and the two runs' histories equal
    (1e-8 of the run's largest value). The explicit solver takes finite sliding through
    the same residual as the implicit one, split per body from one vector in the implicit
    solver's layout; a failure means the split puts forces on the wrong dofs or ranks."""
    sets = ["solver=explicit", "explicit.loading_time=0.01"]
    s = run_case("contact_patch", tmp_path / "serial", sets)
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    assert m["quasi_static"] and m["energy_balance_error_rel"] < 1e-6
    assert m["pressure_deviation_max"] < 0.01
    proc = run_mpi(["cases/contact_patch.py", "--out", str(tmp_path / "mpi"),
                    *[a for kv in sets for a in ("--set", kv)]])
    assert proc.returncode == 0, proc.stderr[-2000:]
    h1 = np.genfromtxt(tmp_path / "serial" / "history.csv", delimiter=",", names=True)
    h2 = np.genfromtxt(tmp_path / "mpi" / "history.csv", delimiter=",", names=True)
    for col in ("sliding_upper_z_N", "energy_internal_Nmm"):
        # at zero load the force is round-off (1.6e-9 N serial, 4.4e-10 N on 2 ranks on
        # an AMD EPYC): it is compared against the run's force, not against zero
        np.testing.assert_allclose(h2[col], h1[col], rtol=1e-8,
                                   atol=1e-8 * np.abs(h1[col]).max())


@pytest.mark.slow
def test_hemisphere_with_sliding_skins_completes(tmp_path):
    """``hemisphere --set skins=true --set blank_holder=true --set skin_contact=finite`` on
    the 8 x 8 x 2 mesh (18.75 mm elements) completes the 50 mm stroke with skins that slide
    more than half an element on the core (measured 14.6 mm), without the small-sliding
    warning, and with the top skin sheared both ways (measured -26.1 to +26.1 deg with the
    case's smoothed interface pressure, l2 line search and stabilisation 1e-4; the
    small-sliding run: -25.3 to +25.3). About 70 s, so in ``scripts/dev.sh validate``.

    The skins' stabilising spring (``skin_stabilisation``) drags on sliding skins, so it
    must carry a small share of the load: from 5 mm of stroke on, the two interfaces'
    spring forces stay below 3% of the punch force (measured 1.5% at the default 1e-4,
    0.15% at 1e-5; at the former default 1e-3, 14%, which put the punch force 2% high
    here and 26% on the default mesh, docs/validation.md). A failure means the spring
    biases the answer."""
    s = run_case("hemisphere", tmp_path, ["skins=true", "blank_holder=true", "cells=8,8,2",
                                          "skin_contact=finite"])
    assert s["status"] == "completed", s["reason"]
    m = s["metrics"]
    assert m["skin_core_slip_max_mm"] > 0.5 * 150.0 / 8
    assert not any("small-sliding" in w for w in s["warnings"])
    assert m["shear_min_deg_skin_top"] < -15.0 < 15.0 < m["shear_max_deg_skin_top"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    late = h["stroke_mm"] >= 5.0
    spring = h["sliding_top_stabilisation_N"] + h["sliding_bottom_stabilisation_N"]
    assert np.all(spring[late] < 0.03 * np.abs(h["force_punch_z_N"][late])), \
        float(np.max(spring[late] / np.abs(h["force_punch_z_N"][late])))


@pytest.mark.slow
def test_hemisphere_springs_stiffen_where_a_step_cannot_be_cut(tmp_path):
    """The 8 x 8 x 2 hemisphere with sliding skins and no holder, its skins' spring at
    1e-6 of the penalty, over the first 1 mm of stroke. With the springs held at their
    setting (``newton.spring_escalation=1``) the first step is cut below the minimum and
    the run stops at 0 mm (measured, 45 s: not rerun here). With the default escalation
    it completes: stiffened twice (to 100 times, 1e-4), back at 1e-6 after 20 steps, and
    its punch force at 1 mm equals the run at the default spring (1e-4 all along) within
    1% (measured 36.029 against 36.051 N, 0.06%). About 130 s, so in ``scripts/dev.sh
    validate``. A failure means the stiffening does not rescue a stalled step, or it
    leaves a bias the spring's own setting would not."""
    base = ["skins=true", "cells=8,8,2", "stroke=1"]
    s = run_case("hemisphere", tmp_path / "weak", [*base, "skin_stabilisation=1e-6"])
    assert s["status"] == "completed", s["reason"]
    t = s["timing"]
    assert t["spring_escalations"] >= 1 and t["spring_stiffened_steps"] > 0, t
    assert any("stiffened" in w for w in s["warnings"])
    h = np.genfromtxt(tmp_path / "weak" / "history.csv", delimiter=",", names=True)
    assert h["spring_scale"].max() > 1.0 and h["spring_scale"][-1] == 1.0
    ref = run_case("hemisphere", tmp_path / "default", base)
    assert ref["status"] == "completed", ref["reason"]
    assert "spring_escalations" in ref["timing"] and ref["timing"]["spring_escalations"] == 0
    f, f_ref = s["metrics"]["punch_force_final_N"], ref["metrics"]["punch_force_final_N"]
    assert f == pytest.approx(f_ref, rel=0.01)


@pytest.mark.mpi
def test_sliding_restart_on_two_ranks_equals_the_uninterrupted_run(tmp_path):
    """The sled (14 mm drag, stabilised) stopped after 7 steps with a checkpoint every 3,
    then restarted from step 6 on two ranks (``--restart``): every history row equals the
    uninterrupted serial run's (1e-6 relative). The checkpoint holds each slave node's
    history master point by its reference coordinates and its friction flag; a failure
    means a piece of the sliding state (multipliers, friction history, the step's
    anchors) does not round-trip or depends on the partition."""
    sets = ["drag=14", "stabilisation=0.001"]
    job, params = prepare_case("sliding_sled", sets)
    job = replace(job, checkpoint_every=3)
    Simulation(job, tmp_path / "whole", "sliding_sled", params, sets).run()
    sim = Simulation(job, tmp_path / "stopped", "sliding_sled", params, sets)
    while sim.stepper.n_accepted < 7:
        sim.step()
    assert sim.finish()["status"] == "stopped"
    proc = run_mpi(["cases/sliding_sled.py", "--restart", str(tmp_path / "stopped")])
    assert proc.returncode == 0, proc.stderr[-2000:]
    _same_histories(tmp_path / "whole", tmp_path / "stopped",
                    ("sliding_skin_x_N", "sliding_skin_z_N", "sliding_skin_stabilisation_N"))


@pytest.mark.slow
@pytest.mark.mpi
def test_hemisphere_with_sliding_skins_on_two_ranks_equals_serial(tmp_path):
    """The same 8 x 8 x 2 hemisphere with finite skins and holder with ``mpirun -n 2``:
    it completes with the serial run's history, forces within 1e-6 relative (measured
    1e-11 over all 129 rows before the smoothed ramp and the l2 line search became the
    case's defaults; passes with them; a rank there owns no core cell; on the default
    20 x 20 x 4 mesh 3e-14, docs/validation.md). About 4 minutes, so in
    ``scripts/dev.sh validate``."""
    sets = ["skins=true", "blank_holder=true", "cells=8,8,2", "skin_contact=finite"]
    s = run_case("hemisphere", tmp_path / "serial", sets)
    assert s["status"] == "completed", s["reason"]
    proc = run_mpi(["cases/hemisphere.py", "--out", str(tmp_path / "mpi"),
                    *[a for kv in sets for a in ("--set", kv)]], timeout=1800)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _same_histories(tmp_path / "serial", tmp_path / "mpi",
                    ("force_punch_z_N", "sliding_top_x_N", "sliding_bottom_z_N"))


def test_a_node_let_go_beyond_the_master_edge_is_not_a_violation(tmp_path):
    """A slave node whose closest point lies a whole fade width beyond the master's open
    edge carries no force (the kernel fades it out), so its penetration must not count
    as a constraint violation, and its multiplier is dropped; the same penetration on
    the master counts in full (1 mm). Counted beyond the edge, it held the one-loop
    Uzawa test at 96 tolerances and a demonstrator run stopped at 28.6 mm. The reported
    penetration is weighted alike (it read 5-10 mm at such nodes)."""
    from forming.contact.slidekernels import FADE

    job = Job(scene=_sled(drag=1.0), steps=StepControl(initial=0.5, max=0.5))
    sim = Simulation(job, tmp_path)
    c = sim.model.sliding[0]
    facet = int(np.flatnonzero(c.master.open_sides[:, 1] > 0)[0])  # an edge at xi = +1
    c.facet[:] = facet
    c.gap[:] = np.inf
    c.lam_n[:] = 0.0
    c.p_new[:] = 0.0
    c.gap[0], c.p_new[0] = -1.0, c.penalty * 1.0  # 1 mm into the master
    c.xi[0] = (0.0, 0.0)
    assert c.violation() == pytest.approx(1.0)
    assert c.penetration() == pytest.approx(1.0)
    c.xi[0] = (1.0 + 1.5 * FADE, 0.0)  # let go entirely
    assert c.violation() == 0.0
    assert c.penetration() == 0.0  # (the history column: no depth past the edge)
    c.lam_n[0] = 5.0
    c.augment()
    assert c.lam_n[0] == 0.0
    c.xi[0] = (1.0 + 0.5 * FADE, 0.0)  # half let go: half counts
    c.lam_n[0] = 0.0
    assert c.violation() == pytest.approx(0.5)


def test_released_springs_leave_less_drag_in_the_sled_s_friction(tmp_path):
    """The sled (14 mm drag in steps of 1.4 mm) with a stiff stabilising spring (1e-2 of
    the penalty) pulls harder than Coulomb's law: the force along x over the normal
    force exceeds the coefficient 0.52 by the spring's drag on each step's slip. Solved
    again from each converged step with the spring at a tenth
    (``newton.spring_release=0.1``), the excess falls to about a tenth (the spring's
    force is linear in its stiffness at the same slip; at most 0.15 of it, either side
    of the coefficient), and every second solve converges and is kept. A failure means
    the second solve does not reach the relaxed answer, or its answer is not the one the
    step keeps."""
    base = ["drag=14", "stabilisation=0.01", "max_step=0.1"]
    s1 = run_case("sliding_sled", tmp_path / "once", base)
    s2 = run_case("sliding_sled", tmp_path / "released", [*base, "newton.spring_release=0.1"])
    assert s1["status"] == s2["status"] == "completed", (s1["reason"], s2["reason"])
    excess = [s["metrics"]["friction_ratio_max"] - MU for s in (s1, s2)]
    assert excess[0] > 1e-3, excess  # the stiff spring's drag shows
    assert abs(excess[1]) < 0.15 * excess[0], excess
    t1, t2 = s1["timing"], s2["timing"]
    assert "spring_release" not in t1
    assert t2["spring_release_solves"] == t2["spring_release_kept"] == t2["steps"]
