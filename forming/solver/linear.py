"""Linear solvers of the Newton iteration: MUMPS, or GAMG with rigid-body modes.

``linear_solver="mumps"`` (direct LU) needs nothing here. ``"gamg"`` is GMRES with
smoothed-aggregation AMG on the whole Jacobian, whose near-null space is the six
rigid-body modes of the model: of its body, or, for several bodies (the monolithic
matrix of a sandwich), of all bodies moving together, written in the monolithic
layout (:func:`rigid_body_modes`).

A block (field-split) preconditioner with one GAMG per body was tried for the
sandwich and failed: block Jacobi and block Gauss-Seidel both stopped at 1000 GMRES
iterations in the first Newton step of ``hemisphere --set skins=true`` (the skins are
held to the core by stiff interface penalties, which the blocks drop); the monolithic
AMG converged in 137-168 iterations to the same answer as MUMPS (docs/performance.md).
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from petsc4py import PETSc

from forming.solver.options import NewtonOptions


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
