"""Why the transversely isotropic core stalled in the hemisphere's first step (issue 15, item 6).

The first load step (0.5 mm of punch travel, 8 x 8 x 2 quarter mesh) of
``hemisphere --set elasticity=transverse`` with each contact numerics, and the evidence
for or against each suspected cause, printed as tables:

1. Newton per variant: converged or not, iterations, the residual where it stopped, the
   die's active-set and stick/slip switches over the iterations, and at the last iterate
   the smallest eigenvalue of the symmetric part of the Jacobian (free dofs), its
   condition number, and the smallest acoustic-tensor eigenvalue over every quadrature
   point (material stability).
2. The old numerics against the step size: the residual where Newton stops scales with
   the step (a positively homogeneous problem: cutting the step cannot help).
3. The old numerics against the contact penalty, and a uniformly soft isotropic core.

The stroke with the holder at a 10 times lower penalty:
``python cases/hemisphere.py --set elasticity=transverse --set cells=12,12,3
--set blank_holder=true --set tool_stick=augmented --set newton.line_search=bt
--set tool_penalty=1``.

Run: ``python benchmarks/transverse_first_step.py`` (about a minute).
"""

from __future__ import annotations

import logging

import numpy as np
import ufl

from forming.case import load_case, prepare_case
from forming.materials import library
from forming.materials.stability import acoustic_min
from forming.model import Model
from forming.solver.implicit import ImplicitSolver

CASE = load_case("hemisphere")
BASE = ("cells=8,8,2",)


def _job(sets: tuple[str, ...], core: dict | None = None):
    """The case's job; ``core``: overrides of an elastic core's parameters."""
    build_core = CASE.honeycomb_core
    if core is not None:
        CASE.honeycomb_core = lambda kind, curve=None, viscosity=0.0: library.honeycomb_core(
            kind, plastic=False, curve=curve, **core)
    try:
        job, _ = prepare_case("hemisphere", [*BASE, *sets], CASE.build, CASE.Params)
    finally:
        CASE.honeycomb_core = build_core
    return job


def _contact_state(model: Model) -> dict[str, np.ndarray]:
    """Per tool: active nodes (trial pressure >= 0) and sliding nodes."""
    state = {}
    for c in model.constraints:
        c._gap.interpolate(c._gap_expr, cells0=c._cells)
        trial = c.lam_n.x.array[c._owned] - c.penalty * c._gap.x.array[c._owned]
        state[c.name] = trial >= 0.0
        if c.lam_t is not None:
            c._t_new.interpolate(c._t_expr, cells0=c._cells)
            shear = np.linalg.norm(c._t_new.x.array.reshape(-1, 3)[c._owned], axis=1)
            limit = c.friction * np.maximum(trial, 0.0)
            state[c.name + "_slip"] = (shear >= limit * (1 - 1e-9)) & (limit > 0)
    return state


def _dense_free(solver: ImplicitSolver, model: Model) -> np.ndarray:
    """The Jacobian at the current iterate, dense, on the free (non-Dirichlet) dofs."""
    x = solver.unknowns()
    n = x.getLocalSize()
    x.array[:] = model.body.u.x.array[:n]
    b = solver.unknowns()
    solver.residual_at(x, b)
    A = solver.jacobian_at(x)
    ai, aj, av = A.getValuesCSR()
    dense = np.zeros((n, n))
    for r in range(n):
        dense[r, aj[ai[r]:ai[r + 1]]] = av[ai[r]:ai[r + 1]]
    free = np.ones(n, dtype=bool)
    for bc in model.dirichlet.bcs:
        idx, owned = bc.dof_indices()
        free[np.asarray(idx)[:owned]] = False
    return dense[np.ix_(free, free)]


def _bulk_taylor(model: Model) -> np.ndarray:
    """Slopes of the second Taylor remainder of the core's own residual at its state.

    2 when the quadrature tangent is the derivative of the quadrature stress.
    """
    from dolfinx import fem  # after forming: PETSc comes from dolfinx_solver

    body = model.body
    v, du = ufl.TestFunction(body.V), ufl.TrialFunction(body.V)
    r_form, j_form = fem.form(body.residual(v)), fem.form(body.jacobian(du, v))
    u0 = body.u.x.array.copy()

    def residual(u: np.ndarray) -> np.ndarray:
        body.u.x.array[:] = u
        body.invalidate()
        body.update_material(want_tangent=True)
        return fem.assemble_vector(r_form).array.copy()

    r0 = residual(u0)
    jd = fem.assemble_matrix(j_form).to_dense() @ (
        d := np.random.default_rng(0).normal(size=u0.size) * 1e-3)
    eps = np.array([1.0, 0.5, 0.25, 0.125])
    rem = [np.linalg.norm(residual(u0 + e * d) - r0 - e * jd) for e in eps]
    residual(u0)
    return np.diff(np.log(rem)) / np.diff(np.log(eps))


def first_step(sets: tuple[str, ...], t: float = 0.01, core: dict | None = None,
               spectrum: bool = True) -> dict:
    """Newton on the first load step to ``t``; what it did and the state it stopped in."""
    job = _job(sets, core)
    model = Model(job.scene)
    model.set_load(0.0)
    solver = ImplicitSolver(model, job.newton)
    states: list[dict] = []
    solver.problem.solver.setMonitor(lambda snes, its, norm: states.append(_contact_state(model)))
    solver.advance(0.0, t, 0.0)
    res = solver.solve()
    pairs = list(zip(states[:-1], states[1:], strict=True))
    switches = {k: int(sum(np.sum(a[k] != b[k]) for a, b in pairs))
                for k in states[0]} if states else {}
    out = {"converged": res.converged, "iterations": res.work,
           "residual_N": res.residuals[-1] if res.residuals else float("nan"),
           "switches": switches,
           "die_active_final": int(states[-1]["die"].sum()) if states else 0,
           "die_nodes": int(states[-1]["die"].size) if states else 0,
           "punch_active_final": int(states[-1]["punch"].sum()) if states else 0,
           "penalty": model.constraints[0].penalty}
    if spectrum:
        jac = _dense_free(solver, model)
        sym = np.linalg.eigvalsh(0.5 * (jac + jac.T))
        sv = np.linalg.svd(jac, compute_uv=False)
        body = model.body
        cj = body._C_expr.eval(body.mesh, body.cells).reshape(-1, 10)[:, :9]
        worst = np.inf
        for c in cj:
            w, v = np.linalg.eigh(0.5 * (c.reshape(3, 3) + c.reshape(3, 3).T))
            worst = min(worst, acoustic_min(body.material, v @ np.diag(np.sqrt(w)) @ v.T)[0])
        out |= {"sym_eig_min": float(sym[0]), "cond": float(sv[0] / sv[-1]),
                "acoustic_min_MPa": worst, "taylor": _bulk_taylor(model)}
    return out


def main() -> None:
    logging.basicConfig(level=logging.ERROR)
    print("## 1. First step (0.5 mm), 8 x 8 x 2\n")
    print("| core | variant | converged | iterations | residual [N] | switches (die active, "
          "die slip, punch active) | active at the end (die of all, punch) "
          "| min eig sym(J) [N/mm] | cond(J) | min acoustic eig [MPa] "
          "| bulk Taylor slopes |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    aug, slip = "tool_stick=augmented", "tool_stick=elastic_slip"
    variants = [("transverse", "augmented, bt (before)", (aug, "newton.line_search=bt")),
                ("transverse", "augmented, basic", (aug, "newton.line_search=basic")),
                ("transverse", "elastic slip, bt", (slip, "newton.line_search=bt")),
                ("transverse", "frictionless, bt", ("friction=0", "newton.line_search=bt")),
                ("transverse", "frictionless, basic", ("friction=0", "newton.line_search=basic")),
                ("transverse", "elastic slip, basic (auto)", ()),
                ("isotropic", "augmented, bt (auto)", ())]
    for core, name, sets in variants:
        r = first_step((f"elasticity={core}", *sets))
        sw = r["switches"]
        print(f"| {core} | {name} | {r['converged']} | {r['iterations']} | "
              f"{r['residual_N']:.2e} | {sw.get('die', 0)}, {sw.get('die_slip', '-')}, "
              f"{sw.get('punch', 0)} | {r['die_active_final']} of {r['die_nodes']}, "
              f"{r['punch_active_final']} | {r['sym_eig_min']:.3g} | {r['cond']:.2e} | "
              f"{r['acoustic_min_MPa']:.4f} | {np.array2string(r['taylor'], precision=2)} |")
    old = ("elasticity=transverse", "tool_stick=augmented", "newton.line_search=bt")
    print("\n## 2. Before (augmented, bt): residual where Newton stops against the step\n")
    print("| step [mm] | converged | residual [N] | residual / step [N/mm] |")
    print("|---|---|---|---|")
    for t in (0.01, 0.005, 0.0025):
        r = first_step(old, t=t, spectrum=False)
        print(f"| {50 * t:g} | {r['converged']} | {r['residual_N']:.3e} | "
              f"{r['residual_N'] / (50 * t):.4f} |")
    print("\n## 3. Before (augmented, bt): contact penalty, and a uniformly soft core\n")
    print("| core | penalty [N/mm^3] | converged | iterations |")
    print("|---|---|---|---|")
    for pen in (0.1, 1.0, 3.0, None, 100.0):
        r = first_step(old + ((f"tool_penalty={pen}",) if pen else ()), spectrum=False)
        label = f"{r['penalty']:.3g}" + (" (default, 10 x 15 MPa / h)" if pen is None else "")
        print(f"| transverse | {label} | {r['converged']} | {r['iterations']} |")
    r = first_step(("elasticity=isotropic", "tool_stick=augmented", "newton.line_search=bt"),
                   core={"E": 0.2}, spectrum=False)
    print(f"| isotropic, E = 0.2 MPa (elastic) | {r['penalty']:.3g} (default) | "
          f"{r['converged']} | {r['iterations']} |")


if __name__ == "__main__":
    main()
