"""Finite-element checks of the Jacobian, Newton convergence and the step lifecycle."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import block_scene, body_taylor, history

from forming.materials.library import honeycomb_core
from forming.model import Model
from forming.solver.implicit import ImplicitSolver
from forming.solver.options import NewtonOptions
from forming.solver.stepping import StepControl, Stepper, StepTooSmall


@pytest.mark.parametrize("regime", ["elastic", "plastic"])
def test_jacobian_taylor(regime):
    """|R(u+e d) - R(u)| falls with slope 1 and |R(u+e d) - R(u) - e J d| with slope 2.

    A slope of 1 for the second remainder would mean the quadrature tangent is not the
    derivative of the quadrature stress (a wrong kernel tangent or a missing term).
    """
    model = Model(block_scene(honeycomb_core("transverse")))
    x = model.body.V.tabulate_dof_coordinates()
    u0 = np.zeros((x.shape[0], 3))
    strain = 0.01 if regime == "elastic" else 0.08  # yield at 0.02
    u0[:, 2] = -strain * x[:, 2]
    u0[:, 0] = 0.02 * x[:, 2] * (regime == "plastic")
    u0 = u0.ravel() + np.random.default_rng(3).normal(size=u0.size) * 1e-3
    model.body.u.x.array[:] = u0
    model.body.invalidate()
    model.body.update_material()
    if regime == "plastic":
        assert model.body.plastic.evp_trial.min() > 1e-3  # every point yields
    s1, s2 = body_taylor(model, u0)
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(np.abs(s2 - 2.0) < 0.15), s2


def test_newton_converges_quadratically():
    """A plastic step of a clamped block (non-uniform field) converges with order 2.

    Orders near 1 would mean an inconsistent tangent; the tangent's O(1e-10) perturbation
    error only shows below the tolerance.
    """
    foam = honeycomb_core("isotropic", nu=0.3)
    model = Model(block_scene(foam, clamped=True, cells=(3, 3, 3), stroke=-4.0))
    solver = ImplicitSolver(model, NewtonOptions(predictor="previous", rtol=1e-12, atol=1e-11))
    solver.advance(0.0, 0.02, 0.0)  # 0.8 mm of 10 mm: 8% strain, beyond yield
    res = solver.solve()
    assert res.converged, res.reason
    r = np.array(res.residuals) / res.residuals[0]
    orders = [np.log(r[k + 1]) / np.log(r[k]) for k in range(1, len(r) - 1)
              if r[k] < 1e-2 and r[k + 1] > 1e-12]
    assert orders, r
    assert max(orders) > 1.8, (orders, r)
    assert res.work <= 8


def test_stepper_grows_cuts_and_lands_on_stops():
    st = Stepper(StepControl(initial=0.1, max=0.3, min=0.01, grow=2.0, cut=0.5,
                             easy_iterations=3, stops=(0.45,)))
    t = st.propose()
    assert t == pytest.approx(0.1)
    st.accept(t, 2)  # easy: grows to 0.2
    assert st.dt == pytest.approx(0.2)
    t = st.propose()
    assert t == pytest.approx(0.3)
    st.accept(t, 10)  # hard: no growth
    assert st.dt == pytest.approx(0.2)
    assert st.propose() == pytest.approx(0.45)  # lands on the stop (0.5 would pass it)
    st.reject()
    assert st.dt == pytest.approx(0.1)
    assert st.propose() == pytest.approx(0.4)
    for _ in range(3):
        st.reject()
    with pytest.raises(StepTooSmall, match="minimum"):
        st.reject()
    st.resume(0.5)  # after a change of model: on at a size within the bounds
    assert st.dt == pytest.approx(0.3)


class _Pair:
    """A stand-in for an interface pair: records the spring scale it is given."""

    def __init__(self, name: str, has_spring: bool):
        self.name, self.has_spring, self.scale = name, has_spring, 1.0

    def scale_spring(self, scale: float) -> None:
        self.scale = scale


def test_spring_escalation_stiffens_holds_and_steps_back():
    """The springs go up by the factor when a step cannot be cut further, to the limit
    and no further; after ``hold`` accepted steps they step back down, one factor at a
    time, to their setting; a checkpoint's state restores all of it. A pair without a
    spring is never touched. A failure means a stiffened run would not return to the
    user's spring, or would stiffen without bound."""
    from forming.springs import SpringEscalation

    sprung, bare = _Pair("top", True), _Pair("tool", False)
    esc = SpringEscalation([sprung, bare], factor=10.0, limit=100.0, hold=2)
    assert esc.active and esc.history_columns() == {"spring_scale": 1.0}
    assert esc.stiffen(0.1) == pytest.approx(10.0) and sprung.scale == pytest.approx(10.0)
    assert esc.stiffen(0.1) == pytest.approx(100.0)
    assert esc.stiffen(0.1) is None and sprung.scale == pytest.approx(100.0)  # the limit
    assert bare.scale == 1.0
    saved = esc.state()
    esc.commit(0.2)
    esc.commit(0.3)
    assert sprung.scale == pytest.approx(10.0)  # held 2 steps: one factor down
    esc.commit(0.4)
    esc.commit(0.5)
    assert sprung.scale == pytest.approx(1.0)
    esc.commit(0.6)
    assert esc.scale == 1.0 and esc.stiffened_steps == 4
    assert esc.summary() == {"spring_escalations": 2, "spring_scale_max": 100.0,
                             "spring_stiffened_steps": 4}
    assert "2 time(s)" in esc.warnings(lambda t: f"t={t}")[0]
    esc.restore(saved)
    assert sprung.scale == pytest.approx(100.0) and esc.stiffened_steps == 0
    esc.restore(None)  # a checkpoint written before the springs were recorded
    assert sprung.scale == 1.0 and esc.warnings(str) == []
    off = SpringEscalation([sprung], factor=1.0, limit=100.0, hold=2)
    assert not off.active and off.stiffen(0.1) is None and off.history_columns() == {}


def test_spring_escalation_settings_are_checked():
    """A factor or limit below 1, a hold below one step, or a release fraction outside
    (0, 1] is refused by its name."""
    from forming.errors import InputError
    from forming.solver.options import NewtonOptions

    for key, value in (("spring_escalation", 0.5), ("spring_escalation_max", float("nan")),
                       ("spring_escalation_hold", 0), ("spring_release", 0.0),
                       ("spring_release", 1.5), ("spring_release", float("nan"))):
        with pytest.raises(InputError, match=f"newton.{key}"):
            NewtonOptions(**{key: value})


def test_multipliers_inside_newton_equal_uzawa(tmp_path):
    """One Newton solve per step with in-loop multiplier updates gives Uzawa's answers.

    The sandwich under the hemisphere (coarse, 8 mm) needs multiplier updates (19 over
    25 steps): ``multipliers="newton"`` makes them inside one SNES solve instead of
    restarting it. The iterates are the same, so every history column (forces,
    iterations, updates) must be equal bit for bit; a difference means the in-loop
    convergence test is not PETSc's default test plus the constraint check.

    The relative test is off (``newton.rtol=1e-30``), so the absolute one decides in both:
    its reference differs by design. Uzawa restarts SNES after an update, so its ``rtol``
    is relative to the residual after the update; in one loop it stays relative to the
    step's first residual. With the default ``rtol`` the first step took 13 iterations
    with Uzawa against 12 in one loop (skin stabilisation 1e-4), all else equal.
    """
    from forming.case import run_case

    sets = ["skins=true", "skin_contact=small", "cells=4,4,1", "stroke=8", "max_step=0.05",
            "newton.rtol=1e-30"]
    runs = {m: run_case("hemisphere", tmp_path / m, [*sets, f"newton.multipliers={m}"])
            for m in ("uzawa", "newton")}
    assert all(s["status"] == "completed" for s in runs.values())
    a, b = history(tmp_path / "uzawa"), history(tmp_path / "newton")
    assert a["augmentations"].sum() > 10  # the updates this test is about happen
    for name in a.dtype.names:
        if name != "step_wall_s":
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_auto_linear_solver_follows_the_size():
    """``auto`` is MUMPS's plain LU below the scaling study's crossing and its block
    low-rank LU from there; a several-body Jacobian drops its exact zeros below
    :data:`DROP_ZEROS_BELOW` unknowns and keeps them from there; MUMPS factorises in
    single precision (refined in double) from :data:`SINGLE_FROM_UNKNOWNS` on, in double
    below (where the two are level: the test suite's models keep it), an AMG solver
    factorises nothing; a choice named explicitly is kept at any size. A failure means
    a model gets a linear solver, a matrix pattern or a precision its size was not
    measured for."""
    from forming.solver.options import (
        BLR_FROM_UNKNOWNS,
        DROP_ZEROS_BELOW,
        SINGLE_FROM_UNKNOWNS,
        NewtonOptions,
    )

    auto = NewtonOptions()
    assert auto.linear_solver == "auto"
    assert auto.for_size(BLR_FROM_UNKNOWNS - 1).linear_solver == "mumps"
    assert auto.for_size(BLR_FROM_UNKNOWNS).linear_solver == "mumps_blr"
    large = auto.for_size(BLR_FROM_UNKNOWNS).petsc_options()
    assert large["approx_mat_mumps_icntl_35"] == "2" and "exact_mat_mumps_icntl_35" not in large
    assert large["approx_ksp_type"] == "fgmres" and large["approx_pc_precision"] == "single"
    blr = NewtonOptions(linear_solver="mumps_blr", lu_precision="double").petsc_options()
    assert blr["approx_ksp_type"] == "gmres" and "approx_pc_precision" not in blr
    single = auto.for_size(SINGLE_FROM_UNKNOWNS).petsc_options()
    assert single["approx_pc_precision"] == "single" and single["approx_ksp_type"] == "richardson"
    assert "exact_pc_precision" not in single and single["exact_ksp_type"] == "preonly"
    assert single["pc_type"] == "none"  # the outer KSP's own PC is never applied
    assert SINGLE_FROM_UNKNOWNS == 5_000
    assert auto.for_size(SINGLE_FROM_UNKNOWNS - 1).lu_precision == "double"
    assert auto.for_size(SINGLE_FROM_UNKNOWNS).lu_precision == "single"
    assert auto.for_size(SINGLE_FROM_UNKNOWNS).petsc_options()["ksp_type"] == "python"
    assert NewtonOptions(linear_solver="gamg").for_size(10**6).lu_precision == "double"
    for named in ("double", "single"):
        assert NewtonOptions(lu_precision=named).for_size(10**7).lu_precision == named
        assert NewtonOptions(lu_precision=named).for_size(10).lu_precision == named
    for named in ("mumps", "gamg", "mumps_blr"):
        assert NewtonOptions(linear_solver=named).for_size(10**7).linear_solver == named
    assert auto.for_size(DROP_ZEROS_BELOW - 1).zeros == "drop"
    assert auto.for_size(DROP_ZEROS_BELOW).zeros == "keep"
    for named in ("drop", "keep"):
        assert NewtonOptions(zeros=named).for_size(10**7).zeros == named
        assert NewtonOptions(zeros=named).for_size(10).zeros == named


@pytest.mark.parametrize(("case", "solver"), [
    ("core_compression", "gamg"), ("skin_sled", "gamg"), ("skin_sled", "mumps_blr"),
    ("core_compression", "mumps,single"), ("skin_sled", "mumps,single"),
    ("skin_sled", "mumps_blr,single")])
def test_iterative_solvers_give_the_direct_solvers_answer(case, solver, tmp_path):
    """GMRES + GAMG (rigid-body near-null space), GMRES on MUMPS's block low-rank LU,
    and MUMPS's LU in single precision refined in double (``,single``:
    ``newton.lu_precision=single``; Richardson, FGMRES with compression) converge to
    MUMPS's answer.

    ``core_compression`` is one body; ``skin_sled`` two (skin and core in one
    monolithic matrix, the modes of both moving together). The linear solves stop at
    1e-10 relative and Newton at its own tolerance, so the converged states differ by what
    that test leaves: up to 1.1e-8 of the largest force on skin_sled (GAMG against
    MUMPS, 2026-12-02); every force column within 1e-7 of it. A failure means the near-null space is
    wrong for the layout (GMRES then stalls), the compressed LU too coarse a
    preconditioner for 200 GMRES iterations, refinement stopping short of the
    tolerance, or the linear tolerance too loose for Newton.

    GAMG's aggressive coarsening does not repeat from run to run, and on ``skin_sled`` some
    runs took another number of Newton iterations in a step (docs/performance.md, "GAMG is
    not the same from run to run"): the iterative run gets up to three tries, and one must
    match.
    """
    from forming.case import run_case

    s = run_case(case, tmp_path / "mumps", ["newton.linear_solver=mumps"])
    assert s["status"] == "completed", s["reason"]
    a = history(tmp_path / "mumps")
    forces = [n for n in a.dtype.names if n.startswith(("force_", "reaction_"))]
    scale = max(np.abs(a[n]).max() for n in forces)

    def mismatch(b) -> str:
        if not np.array_equal(a["newton_iterations"], b["newton_iterations"]):
            return f"Newton iterations {b['newton_iterations']} against {a['newton_iterations']}"
        worst = {n: np.abs(a[n] - b[n]).max() / scale for n in forces}
        return "" if max(worst.values()) <= 1e-7 else f"forces apart: {worst}"

    why = []
    for attempt in range(3):
        out = tmp_path / f"{solver}{attempt}"
        name, _, precision = solver.partition(",")
        s = run_case(case, out, [f"newton.linear_solver={name}",
                                 f"newton.lu_precision={precision or 'double'}"])
        assert s["status"] == "completed", s["reason"]
        why.append(mismatch(history(out)))
        if not why[-1]:
            break
    assert not why[-1], why


class _SinglePrecisionKSP:
    """A Newton solver's single-precision KSP on ``A`` (its options under a test prefix).

    A context manager: the options are removed and the KSP destroyed on exit.
    """

    def __init__(self, A, prefix: str = "refined_test_"):
        from petsc4py import PETSc

        from forming.solver.options import NewtonOptions

        keys = NewtonOptions(linear_solver="mumps", lu_precision="single").petsc_options()
        self._keys = [prefix + k for k in keys if not k.startswith("snes_")]
        self._opts = PETSc.Options()
        for k, v in keys.items():
            if not k.startswith("snes_"):
                self._opts[prefix + k] = v
        self.ksp = PETSc.KSP().create(A.getComm())
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setOperators(A)
        self.ksp.setFromOptions()

    def __enter__(self):
        return self.ksp

    def __exit__(self, *exc) -> None:
        for k in self._keys:
            self._opts.delValue(k)
        self.ksp.destroy()


def _errors(A, x, b) -> tuple[float, float]:
    """Relative residual of ``A x = b`` and its normwise backward error.

    The backward error is what a stable LU keeps at round-off, whatever the condition
    number.
    """
    from petsc4py import PETSc

    r = b.duplicate()
    A.mult(x, r)
    r.axpy(-1.0, b)
    inf = PETSc.NormType.INFINITY
    return r.norm() / b.norm(), r.norm(inf) / (A.norm(inf) * x.norm(inf) + b.norm(inf))


def _refined_lu_solve(A, times: int = 1):
    """Solve ``A x = 1`` with a Newton solver's single-precision KSP, ``times`` times.

    Returns:
        The KSP's :class:`RefinedLU`, the relative residual, the normwise backward error
        and the KSP's reason.
    """
    from forming.solver.linear import refined_lu

    with _SinglePrecisionKSP(A) as ksp:
        b = A.createVecLeft()
        b.set(1.0)
        x = b.duplicate()
        for _ in range(times):
            ksp.solve(b, x)
        res, backward = _errors(A, x, b)
        return refined_lu(ksp), res, backward, ksp.getConvergedReason()


def _laplacian(n: int, shift: float):
    """The 1D Laplacian with free ends plus ``shift`` on the diagonal (AIJ, serial)."""
    from petsc4py import PETSc

    A = PETSc.Mat().createAIJ([n, n], nnz=3, comm=PETSc.COMM_SELF)
    for i in range(n):
        cols = [j for j in (i - 1, i, i + 1) if 0 <= j < n]
        vals = [-1.0 if j != i else len(cols) - 1 + shift for j in cols]
        A.setValues(i, cols, vals)
    A.assemble()
    return A


def test_the_single_precision_lu_is_refined_or_falls_back_to_the_exact_one():
    """A single-precision LU refined in double solves to 1e-10, or hands over to double.

    A well-conditioned matrix (the 1D Laplacian shifted by 1: condition number about 5)
    is solved by refinement alone, in a few iterations, to the tolerance 1e-10 on the
    true residual. A nearly singular one (shifted by 1e-10: condition number about
    4e10, far past what single precision's round-off 6e-8 can refine) stops refining,
    and the double LU of the same matrix gives the answer: its normwise backward error
    at double round-off (1e-13 allowed), where ten refinements of the single LU leave
    it at 6e-9 and a residual 13 times the right-hand side.
    Solved again and again, the nearly singular matrix stops the refinement for good
    after two solves (every later solve goes to the exact LU at once).
    A failure means the refinement stops short of the tolerance, or the fallback does
    not happen and Newton would get a wrong step, or a model that refinement cannot
    solve keeps paying for it.
    """
    ctx, res, backward, reason = _refined_lu_solve(_laplacian(200, 1.0))
    assert reason > 0 and res <= 1e-10 and backward <= 1e-13, (reason, res, backward)
    assert ctx.counts()["exact_fallbacks"] == 0 and ctx.counts()["refinement_iterations"] <= 4
    ctx, res, backward, reason = _refined_lu_solve(_laplacian(200, 1e-10))
    assert reason > 0 and backward <= 1e-13, (reason, res, backward)
    assert ctx.counts()["exact_fallbacks"] == 1, ctx.counts()
    # a model whose every solve falls back stops trying refinement after two solves
    ctx, res, backward, reason = _refined_lu_solve(_laplacian(200, 1e-10), 4)
    assert reason > 0 and backward <= 1e-13, (reason, res, backward)
    assert ctx.counts()["exact_only"] and ctx.counts()["exact_fallbacks"] == 4
    assert ctx.counts()["refinement_iterations"] == 2 * 10, ctx.counts()


def test_a_fallback_holds_one_factorisation_at_a_time():
    """After an exact fallback the approximate LU is the first try again, in single.

    A fallback frees the approximate factors before the exact LU is made, and the exact
    factors once its solve is done (a Newton iteration's next Jacobian is factorised
    anew), so the two are never held at once (the memory of both: about 1.5 times the
    double LU's). One KSP solves the nearly singular matrix (a fallback), then the
    well-conditioned one: that solve must again be the single-precision LU refined
    (at least 2 Richardson iterations: the double LU would take 1) with no new fallback,
    to the tolerance; and the nearly singular one again falls back and is solved at
    double round-off. A failure means a fallback left the approximate solver without
    its settings (a double LU, or no LU), or freed a factorisation still in use.
    """
    from forming.solver.linear import refined_lu

    hard, easy = _laplacian(200, 1e-10), _laplacian(200, 1.0)
    with _SinglePrecisionKSP(hard, "refined_reset_") as ksp:
        b = hard.createVecLeft()
        b.set(1.0)
        x = b.duplicate()
        ksp.solve(b, x)
        ctx = refined_lu(ksp)
        assert ctx.counts()["exact_fallbacks"] == 1
        before = ctx.counts()["refinement_iterations"]
        ksp.setOperators(easy)
        ksp.solve(b, x)
        res, _ = _errors(easy, x, b)
        assert ksp.getConvergedReason() > 0 and res <= 1e-10
        counts = ctx.counts()
        assert counts["exact_fallbacks"] == 1 and not counts["exact_only"], counts
        assert 2 <= counts["refinement_iterations"] - before <= 4, counts
        ksp.setOperators(hard)
        ksp.solve(b, x)
        _, backward = _errors(hard, x, b)
        assert ctx.counts()["exact_fallbacks"] == 2
        assert ksp.getConvergedReason() > 0 and backward <= 1e-13, backward


def test_the_lifting_left_out_where_it_is_zero_changes_no_bit(monkeypatch):
    """The implicit residual leaves out the Dirichlet lifting ``-J (g - u)`` when every
    prescribed dof holds its value (it costs a Jacobian assembly over the cells with such
    dofs, and is then exactly zero). A step of a block whose top is pushed down (the one
    prescribed value that moves) with symmetry planes: the prescribed values are not held
    when the step starts and are held when it ends, and the step's residual history and
    displacement are the same to the bit as with the lifting always assembled. A failure
    means the shortcut skipped a lifting that was not zero, or assembles another vector.
    """
    from forming.model import DirichletSet

    foam = honeycomb_core("isotropic", nu=0.3)

    def step():
        model = Model(block_scene(foam, cells=(2, 2, 2), stroke=-4.0))
        solver = ImplicitSolver(model, NewtonOptions(predictor="previous"))
        solver.advance(0.0, 0.02, 0.0)
        before = model.dirichlet.held()
        res = solver.solve()
        assert res.converged, res.reason
        return before, model.dirichlet.held(), res.residuals, model.body.u.x.array.copy()

    before, after, residuals, u = step()
    assert not before and after
    monkeypatch.setattr(DirichletSet, "held", lambda self: False)
    _, _, residuals_lifted, u_lifted = step()
    assert residuals == residuals_lifted
    assert np.array_equal(u, u_lifted)


def test_a_stalled_newton_solve_gives_up_early(tmp_path):
    """``newton.stall`` ends a solve whose residual stopped falling; bad values refused.

    ``core_crushing`` on 4 x 4 x 3 elements: the second step, to 1 mm into the crushing
    core, stalls under the backtracking line search (it spends all 25 iterations at an
    almost constant residual without the option). With ``stall=5`` the solve must give up as soon
    as the residual has fallen by less than a tenth over 5 iterations, with its own
    reason, so that the step is cut at once. A failure means the rule fires too late, not
    at all, or on a residual that was still falling.
    """
    from forming.case import prepare_case
    from forming.errors import InputError
    from forming.simulation import Simulation

    with pytest.raises(InputError, match="newton.stall"):
        NewtonOptions(stall=-1)
    sets = ["cells=4,4,3", "newton.stall=5"]
    job, params = prepare_case("core_crushing", sets)
    sim = Simulation(job, tmp_path, "core_crushing", params, sets)
    try:
        for _ in range(5):  # up to the first failed step
            if not (res := sim.step()).converged:
                break
    finally:
        sim.solver.close()
    assert not res.converged and res.reason.startswith("stalled")
    r = res.residuals
    assert 5 <= res.work < 25 and len(r) == res.work + 1
    assert r[-1] > 0.9 * r[-6]  # the rule held where it fired ...
    assert all(r[i] <= 0.9 * r[i - 5] for i in range(5, len(r) - 1))  # ... and not before
