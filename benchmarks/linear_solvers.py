"""Time the linear solvers on one Newton Jacobian of the hemisphere with blank holder.

Builds ``hemisphere --set blank_holder=true`` on a mesh (default the 20 x 20 x 4 quarter
mesh), evaluates the core at a small random displacement, assembles the Jacobian with
its Dirichlet rows, and times, per solver, the first set-up and solve and a second
numeric set-up and solve on the same pattern, the best of ``--repeats`` (what every
later Newton iteration pays):
MUMPS LU with its default ordering and with METIS (ICNTL(7) = 5) and PORD (4),
MUMPS's block low-rank LU (ICNTL(35) = 2) at three compression tolerances preconditioning
GMRES, MUMPS's LU in single precision refined in double (plain and compressed),
SuperLU_dist LU, and GMRES + GAMG with the rigid-body modes (rtol 1e-10).
``--skip`` leaves out solvers whose name contains a given text (GAMG and SuperLU_dist
take minutes on large meshes).

Run: ``python benchmarks/linear_solvers.py [--cells 20,20,4]`` (seconds).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import dolfinx_solver  # noqa: F401  (PETSc before dolfinx)

import numpy as np
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, create_matrix
from petsc4py import PETSc

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases"))
import hemisphere  # noqa: E402

from forming.model import Model  # noqa: E402
from forming.solver import linear  # noqa: E402


def _direct(package: str, icntl7: int | None = None):
    def setup(ksp):
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType(package)
        if icntl7 is not None:
            pc.setFactorSetUpSolverType()
            pc.getFactorMatrix().setMumpsIcntl(7, icntl7)
    return setup


def _blr(tolerance: float):
    """MUMPS's block low-rank LU at ``tolerance`` preconditioning GMRES (``mumps_blr``)."""
    def setup(ksp):
        ksp.setType("gmres")
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setTolerances(rtol=1e-10, max_it=200)
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        pc.setFactorSetUpSolverType()
        pc.getFactorMatrix().setMumpsIcntl(35, 2)
        pc.getFactorMatrix().setMumpsCntl(7, tolerance)
    return setup


def _single(blr: float | None = None):
    """MUMPS's LU in single precision refined in double to 1e-10 (``lu_precision=single``).

    The refinement is what :class:`forming.solver.linear.RefinedLU` runs first:
    Richardson on the true residual, or FGMRES where the LU is compressed too.
    """
    def setup(ksp):
        prefix = f"single{id(ksp)}_"
        opts = PETSc.Options()
        opts[f"{prefix}pc_precision"] = "single"
        ksp.setOptionsPrefix(prefix)
        if blr is None:
            ksp.setType("richardson")
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        else:
            ksp.setType("fgmres")
        ksp.setTolerances(rtol=1e-10, max_it=10)
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        pc.setFromOptions()
        pc.setFactorSetUpSolverType()
        if blr is not None:
            pc.getFactorMatrix().setMumpsIcntl(35, 2)
            pc.getFactorMatrix().setMumpsCntl(7, blr)
    return setup


def _gamg(A, spaces):
    def setup(ksp):
        A.setNearNullSpace(linear.rigid_body_modes(A, spaces))
        ksp.setType("gmres")
        ksp.getPC().setType("gamg")
        ksp.setTolerances(rtol=1e-10, max_it=1000)
        opts = PETSc.Options()
        opts["pc_gamg_threshold"] = 0.01
        opts["mg_levels_ksp_type"] = "chebyshev"
        opts["mg_levels_pc_type"] = "jacobi"
        ksp.setFromOptions()
    return setup


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", default="20,20,4")
    parser.add_argument("--skip", nargs="*", default=[], help="solvers to leave out")
    parser.add_argument("--repeats", type=int, default=3,
                        help="numeric factorisations timed on the known pattern (the best)")
    args = parser.parse_args()
    cells = tuple(int(c) for c in args.cells.split(","))
    job = hemisphere.build(hemisphere.Params(cells=cells, blank_holder=True))
    model = Model(job.scene)
    body = next(iter(model.bodies.values()))
    rng = np.random.default_rng(0)
    body.u.x.array[:] = 1e-3 * rng.standard_normal(body.u.x.array.size)
    body.update_material(True)
    form = fem.form(model.jacobians()[0][0], entity_maps=model.entity_maps or None)
    A = create_matrix(form)
    assemble_matrix(A, form, bcs=model.dirichlet.bcs)
    A.assemble()
    b = A.createVecLeft()
    b.set(1.0)
    x = b.duplicate()
    solvers = {"MUMPS (default ordering)": _direct("mumps"),
               "MUMPS, METIS (ICNTL(7)=5)": _direct("mumps", 5),
               "MUMPS, PORD (ICNTL(7)=4)": _direct("mumps", 4),
               "MUMPS BLR 1e-6 + GMRES": _blr(1e-6),
               "MUMPS BLR 1e-4 + GMRES (mumps_blr)": _blr(1e-4),
               "MUMPS BLR 1e-3 + GMRES": _blr(1e-3),
               "MUMPS single, refined (lu_precision=single)": _single(),
               "MUMPS BLR 1e-4 single + FGMRES (mumps_blr, lu_precision=single)":
                   _single(1e-4),
               "SuperLU_dist": _direct("superlu_dist"),
               "GMRES + GAMG": _gamg(A, [body.V])}
    print(f"hemisphere, blank holder, {args.cells} quarter mesh: {A.getSize()[0]} unknowns, "
          f"{A.getInfo()['nz_used']:.0f} non-zeros\n")
    print(f"| solver | first set-up + solve [ms] | again, same pattern, best of {args.repeats} "
          "[ms] | iterations |")
    print("|---|---|---|---|")
    for name, setup in solvers.items():
        if any(k in name for k in args.skip):
            continue
        ksp = PETSc.KSP().create(A.comm)
        ksp.setOperators(A)
        setup(ksp)
        t0 = time.perf_counter()
        ksp.setUp()
        ksp.solve(b, x)
        t1 = time.perf_counter()
        again = []
        for _ in range(args.repeats):
            A.assemble()  # the next Newton iteration: new values, same pattern
            ksp.setOperators(A)
            t2 = time.perf_counter()
            ksp.setUp()
            ksp.solve(b, x)
            again.append(time.perf_counter() - t2)
        its = ksp.getIterationNumber()
        status = "" if ksp.getConvergedReason() > 0 else f" ({ksp.getConvergedReason()})"
        print(f"| {name} | {1e3 * (t1 - t0):.1f} | {1e3 * min(again):.1f} | {its}{status} |",
              flush=True)
        ksp.destroy()


if __name__ == "__main__":
    main()
