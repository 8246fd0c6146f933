"""Linear solvers of the Newton iteration: MUMPS, or GAMG with rigid-body modes.

``linear_solver="mumps"`` (direct LU) needs nothing here, unless it factorises in single
precision (``lu_precision="single"``) or compresses (``"mumps_blr"``): :class:`RefinedLU`
then refines each solve in double and falls back to the exact LU where that fails.
``"gamg"`` is GMRES with smoothed-aggregation AMG on the whole Jacobian, whose near-null
space is the six rigid-body modes of the model: of its body, or, for several bodies
(the monolithic matrix of a sandwich), of all bodies moving together, written in the
monolithic layout (:func:`rigid_body_modes`).

A block (field-split) preconditioner with one GAMG per body was tried for the
sandwich and failed: block Jacobi and block Gauss-Seidel both stopped at 1000 GMRES
iterations in the first Newton step of ``hemisphere --set skins=true`` (the skins are
held to the core by stiff interface penalties, which the blocks drop); the monolithic
AMG converged in 137-168 iterations to the same answer as MUMPS (docs/performance.md).
"""

from __future__ import annotations

import logging

import numpy as np
from dolfinx import fem
from petsc4py import PETSc

from forming.log import collective_warning
from forming.solver.options import NewtonOptions

log = logging.getLogger(__name__)


def block_index_sets(A: PETSc.Mat, spaces: list[fem.FunctionSpace]) -> list[PETSc.IS]:
    """Index sets of each space's rows in a matrix over the spaces in turn.

    Each rank owns its rows of every block in turn (DOLFINx's ``kind="mpi"`` layout):
    block ``i`` starts after the rank's first row plus the owned sizes of the blocks
    before it. One space gives the whole matrix.
    """
    start = A.getOwnershipRange()[0]
    sets = []
    for V in spaces:
        n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        sets.append(PETSc.IS().createStride(n, first=start, step=1, comm=A.getComm()))
        start += n
    return sets


def rigid_body_modes(A: PETSc.Mat, spaces: list[fem.FunctionSpace]) -> PETSc.NullSpace:
    """The three translations and three rotations of all bodies together, orthonormal.

    Args:
        A: The Jacobian (its row layout).
        spaces: The bodies' displacement spaces (vector P1 or P2), in block order.
    """
    vecs = [A.createVecRight() for _ in range(6)]
    start = A.getOwnershipRange()[0]
    for V, index_set in zip(spaces, block_index_sets(A, spaces), strict=True):
        n = V.dofmap.index_map.size_local
        x = V.tabulate_dof_coordinates()[:n]
        modes = np.zeros((6, n, 3))
        for i in range(3):
            modes[i, :, i] = 1.0
        modes[3, :, 0], modes[3, :, 1] = -x[:, 1], x[:, 0]
        modes[4, :, 1], modes[4, :, 2] = -x[:, 2], x[:, 1]
        modes[5, :, 0], modes[5, :, 2] = x[:, 2], -x[:, 0]
        rows = index_set.getIndices() - start
        for v, m in zip(vecs, modes, strict=True):
            v.array[rows] = m.ravel()
    for i, v in enumerate(vecs):  # modified Gram-Schmidt
        for w in vecs[:i]:
            v.axpy(-v.dot(w), w)
        v.scale(1.0 / v.norm())
    return PETSc.NullSpace().create(vectors=vecs, comm=A.getComm())


def configure(A: PETSc.Mat, spaces: list[fem.FunctionSpace], options: NewtonOptions) -> None:
    """Give the Jacobian ``A`` what the chosen linear solver needs (GAMG: its modes)."""
    if options.linear_solver == "gamg":
        A.setNearNullSpace(rigid_body_modes(A, spaces))


class RefinedLU:
    """A KSP (``ksp_type python``): an approximate LU made exact, or the exact LU.

    The approximate factorisation is MUMPS's in single precision (half the memory
    traffic of the double LU, twice the numbers per vector instruction), its block
    low-rank compression (``mumps_blr``), or both; an iteration in double precision on
    the true residual makes each solve exact to ``ksp_rtol`` 1e-10 (the inner KSP of
    prefix ``<prefix>approx_``): Richardson, ``x += LU^-1 (b - A x)``, on the
    single-precision LU; GMRES on the compressed one; FGMRES on both, since a
    preconditioner applied in single precision is not the same linear map twice, which
    GMRES assumes. Refinement converges while the Jacobian's condition number times
    the factorisation's error stays well below 1; where it has not converged within its
    iterations (a crushing core with elements near inversion, the thin walls of a meso
    patch), the same matrix is factorised exactly, by MUMPS's plain LU in double
    precision (prefix ``<prefix>exact_``), and that solve is the answer. Either way the
    Newton step is the exact LU's to the linear tolerance, and the two factorisations
    are never held at once (a fallback frees the approximate factors before it, the exact
    ones after it: the next Jacobian is factorised anew). Once two solves have fallen
    back and they are more than half of the solves so far, the approximate
    factorisation is dropped (its memory freed) and every later solve is exact at
    once. See docs/theory.md, section 7.
    """

    def __init__(self) -> None:
        self._approx: PETSc.KSP | None = None
        self._exact: PETSc.KSP | None = None
        self.solves = 0  # linear solves
        self.refinements = 0  # iterations on the approximate LU over them
        self.fallbacks = 0  # solves made with the exact LU
        self.exact_only = False  # the approximate LU given up: exact from here on

    def _inner(self, ksp: PETSc.KSP, suffix: str) -> PETSc.KSP:
        inner = PETSc.KSP().create(ksp.getComm())
        inner.setOptionsPrefix(f"{ksp.getOptionsPrefix() or ''}{suffix}")
        inner.setFromOptions()
        return inner

    def setUp(self, ksp: PETSc.KSP) -> None:  # noqa: N802 (petsc4py's name)
        """Create the two inner solvers (their options are read once, here)."""
        if self._exact is None:
            self._approx = self._inner(ksp, "approx_")
            self._exact = self._inner(ksp, "exact_")

    def solve(self, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """The approximate LU refined; the exact LU where refinement fails."""
        A, P = ksp.getOperators()
        self.solves += 1
        its, reason = 0, 0
        if not self.exact_only:
            self._approx.setOperators(A, P)
            self._approx.solve(b, x)
            its = self._approx.getIterationNumber()
            reason = self._approx.getConvergedReason()
            self.refinements += its
        if reason <= 0:
            self.fallbacks += 1
            if self.fallbacks == 1:
                log.info("linear solve: refining the approximate LU stopped (%s after %d "
                         "iterations); this Jacobian is factorised exactly",
                         _KSP_REASONS.get(reason, reason), its)
            if not self.exact_only and self.fallbacks >= 2 and 2 * self.fallbacks > self.solves:
                self.exact_only = True
                self._approx.destroy()  # its factors' memory
                self._approx = None
                collective_warning(log, "linear solve: %d of %d solves on the approximate LU "
                                   "needed the exact one; the rest of the run factorises "
                                   "exactly", self.fallbacks, self.solves)
            elif not self.exact_only:
                # the approximate factors are of this matrix alone (the next Jacobian is
                # factorised anew): freed before the exact ones are made, so that the two
                # are never held at once
                self._approx.reset()
            self._exact.setOperators(A, P)
            self._exact.solve(b, x)
            reason = self._exact.getConvergedReason()
            its += self._exact.getIterationNumber()
            if not self.exact_only:
                self._exact.reset()  # the next Jacobian tries the approximate LU first
        ksp.setIterationNumber(its)
        ksp.setConvergedReason(reason)

    def destroy(self, ksp: PETSc.KSP) -> None:
        """Destroy the inner solvers and their factors."""
        for inner in (self._approx, self._exact):
            if inner is not None:
                inner.destroy()
        self._approx = self._exact = None

    def counts(self) -> dict[str, int | bool]:
        """Solves, refinement iterations and exact fallbacks so far."""
        return {"linear_solves": self.solves, "refinement_iterations": self.refinements,
                "exact_fallbacks": self.fallbacks, "exact_only": self.exact_only}


_KSP_REASONS = {v: k for k, v in vars(PETSc.KSP.ConvergedReason).items()
                if isinstance(v, int)}


def refined_lu(ksp: PETSc.KSP) -> RefinedLU | None:
    """The :class:`RefinedLU` context of a Newton solver's KSP, if it has one."""
    if ksp.getType() != "python":
        return None
    ctx = ksp.getPythonContext()
    return ctx if isinstance(ctx, RefinedLU) else None
