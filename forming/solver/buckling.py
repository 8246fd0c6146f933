"""Linear (eigenvalue) buckling about the undeformed state, as Abaqus's ``*BUCKLE``.

The scene's loading programme at load parameter ``t`` is the reference load. A small
step ``t = eps`` is solved with Newton; the differential stiffness per unit load is
``K_delta = (K(eps) - K(0)) / eps`` (initial-stress and initial-displacement terms,
exactly as the implicit solver assembles its Jacobian, prescribed rows and columns
removed); and the buckling load factors ``lambda`` solve

    K(0) phi = -lambda K_delta phi,

which SLEPc solves as the symmetric-definite problem ``-K_delta phi = theta K(0) phi``
with ``theta = 1 / lambda``, largest ``theta`` first (one LU factorisation of ``K(0)``).
A factor is the load parameter at which the linearised structure loses stability; the
modes seed geometric imperfections (:mod:`forming.meso.honeycomb`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dolfinx.fem.petsc import assign  # noqa: I001
from mpi4py import MPI
from petsc4py import PETSc

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.errors import InputError, SolveFailure
from forming.model import Model
from forming.solver.implicit import ImplicitSolver


@dataclass(frozen=True)
class BucklingModes:
    """The lowest buckling load factors and their modes.

    Attributes:
        factors: Load parameters at buckling, ascending (positive only).
        modes: Per mode, every body's displacement array (owned and ghost entries, in
            the model's body order), scaled to a largest nodal move of 1.
    """

    factors: np.ndarray
    modes: list[list[np.ndarray]]


def buckling_modes(model: Model, solver: ImplicitSolver, n_modes: int = 3,
                   eps: float = 1e-3) -> BucklingModes:
    """Buckling load factors of the model's loading programme about ``t = 0``.

    The model is returned to its undeformed state at ``t = 0``.

    Args:
        model: The model, undeformed, at ``t = 0``.
        solver: An implicit solver of that model.
        n_modes: How many factors to compute.
        eps: Load parameter of the pre-buckling step (the response must be linear up
            to it).

    Raises:
        InputError: The model has contact, interfaces or a stabilisation.
        SolveFailure: The pre-buckling step did not converge, or SLEPc found no
            positive factor.
    """
    from slepc4py import SLEPc

    if model.constraints or model.stabilisation is not None:
        raise InputError("buckling", "a linear buckling analysis needs a model whose "
                         "stiffness changes linearly with the load: no contact, interface "
                         "or stabilisation (hold the supports with prescribed displacements)")
    bodies = list(model.bodies.values())
    functions = [b.u for b in bodies] if len(bodies) > 1 else bodies[0].u
    x = solver.unknowns()
    x.zeroEntries()
    k0 = solver.jacobian_at(x).copy()
    solver.advance(0.0, eps, 0.0)
    step = solver.solve()
    if not step.converged:
        raise SolveFailure(f"buckling: the pre-buckling step to t = {eps:g} did not "
                           f"converge ({step.reason})")
    assign(functions, x)
    kd = solver.jacobian_at(x).copy()
    kd.axpy(-1.0, k0)  # K(eps) - K(0): zero on the prescribed rows and columns
    kd.scale(-1.0 / eps)
    eps_solver = SLEPc.EPS().create(model.comm)
    eps_solver.setOperators(kd, k0)
    eps_solver.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps_solver.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL)
    eps_solver.setDimensions(n_modes)
    eps_solver.setTolerances(1e-10, 500)
    st = eps_solver.getST()
    st.setType(SLEPc.ST.Type.SHIFT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.LU)
    pc.setFactorSolverType("mumps")
    eps_solver.solve()
    found = []
    vec = solver.unknowns()  # ghosted, in the layout ``assign`` expects
    for i in range(eps_solver.getConverged()):
        theta = eps_solver.getEigenpair(i, vec).real
        if theta > 0:
            vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            assign(vec, functions)
            for b in bodies:
                b.u.x.scatter_forward()
            arrays = [b.u.x.array.copy() for b in bodies]
            peak = max(float(np.abs(a).max()) if a.size else 0.0 for a in arrays)
            peak = model.comm.allreduce(peak, op=MPI.MAX)
            found.append((1.0 / theta, [a / peak for a in arrays]))
    for b in bodies:
        b.u.x.array[:] = 0.0
        b.invalidate()
    model.set_load(0.0)
    for m in (k0, kd, vec, eps_solver):
        m.destroy()
    if not found:
        raise SolveFailure("buckling: no positive load factor (the loading does not "
                           "compress anything that can buckle)")
    found.sort(key=lambda item: item[0])
    found = found[:n_modes]
    return BucklingModes(np.array([f for f, _m in found]), [m for _f, m in found])
