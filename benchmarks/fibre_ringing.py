"""Why the explicit picture frame needs its fibres damped: the bound holds, the toe does not.

Runs ``picture_frame`` explicitly (default 8 x 8 ply, serial) with a given
``explicit.fibre_damping`` and, after every output interval, the largest eigenvalue of
``M^-1 K`` over the free dofs, with K the fabric's consistent tangent at that state, and
with the taut-fibre tangent that the Gershgorin bound uses. It prints ``omega_max dt``
for both, the kinetic energy and the energy balance: central differences are stable for
the linearised system while ``omega_max dt < 2``. Undamped (``0``), the run goes unstable
although ``omega_max dt`` stays below 1.6 at every interval: the energy comes from the
fibres' toe, which the linearisation does not see (docs/theory.md, section 12).

Run: ``python benchmarks/fibre_ringing.py [--damping 0.0]`` (about a minute; dense
eigenvalues of a 486-dof ply).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import ufl

from forming.case import prepare_case
from forming.simulation import Simulation


def _omega2_max(form, mass: np.ndarray, free: np.ndarray) -> float:
    """Largest eigenvalue of ``M^-1 K`` on the free dofs (dense, serial)."""
    from dolfinx.fem.petsc import assemble_matrix  # after forming: PETSc from dolfinx_solver

    A = assemble_matrix(form)
    A.assemble()
    indptr, cols, data = A.getValuesCSR()
    A.destroy()
    n = len(indptr) - 1
    K = np.zeros((n, n))
    K[np.repeat(np.arange(n), np.diff(indptr)), cols] = data
    s = 1.0 / np.sqrt(mass[free])
    return float(np.linalg.eigvalsh(s[:, None] * K[np.ix_(free, free)] * s[None, :]).max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--damping", type=float, default=0.0,
                        help="explicit.fibre_damping (default 0: undamped)")
    args = parser.parse_args()
    from dolfinx import fem  # after forming: PETSc comes from dolfinx_solver

    job, _ = prepare_case("picture_frame", ["solver=explicit",
                                            f"explicit.fibre_damping={args.damping}"])
    with tempfile.TemporaryDirectory() as tmp:
        sim = Simulation(job, Path(tmp), "picture_frame")
        st = sim.solver.states[0]
        body = st.body
        du, v = ufl.TrialFunction(body.V), ufl.TestFunction(body.V)
        true_k = fem.form(body.jacobian(du, v))
        taut_k = fem.form(body.stability_jacobian(du, v))
        free = ~st.fixed
        print("load  dt [s]     w_true dt  w_taut dt  kinetic [N mm]  balance [N mm]")
        worst = 0.0
        while not sim.done:
            result = sim.step()
            if not result.converged:
                print(f"stopped at load {sim.t:.2f}: {result.reason}")
                break
            dt = sim.solver.dt
            w_true = np.sqrt(_omega2_max(true_k, st.m, free)) * dt
            w_taut = np.sqrt(_omega2_max(taut_k, st.m, free)) * dt
            worst = max(worst, w_true)
            e = sim.solver.ledger.energy
            print(f"{sim.t:.2f}  {dt:.3e}  {w_true:9.3f}  {w_taut:9.3f}  {e['kinetic']:14.4g}"
                  f"  {sim.solver.balance():14.4g}")
        sim.finish()
        print(f"largest omega_max dt of the consistent tangent: {worst:.3f} (stable below 2)")


if __name__ == "__main__":
    main()
