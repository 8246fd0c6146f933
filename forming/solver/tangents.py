"""The implicit solver's Jacobian with a body's element matrices compiled, not from forms.

A one-body model whose body offers compiled element matrices
(:meth:`~forming.bodies.base.DeformableBody.compiled_tangent`: a solid of trilinear
hexahedra) gets its Jacobian in two parts:

1. the body's own tangent, from :class:`~forming.bodies.hextangent.HexTangent`: the
   element matrices summed into the matrix's distinct entries in the compiled loop (where
   each element entry goes is worked out once), handed to PETSc in one call of its
   coordinate assembly (``MatSetValuesCOO``), with the rows and columns of prescribed
   dofs left out and a 1 on their diagonal, as DOLFINx does;
2. everything else the model linearises through UFL (tool contacts, viscous
   stabilisation), assembled from the forms on top.

The matrix's pattern becomes the element matrices' (every other term of a one-body model
lives on the body's cells). The solution is the same to round-off as with the forms
(``tests/test_hextangent.py``); ``newton.jacobian=forms`` keeps the forms alone.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem  # noqa: I001
from dolfinx.fem.petsc import assemble_matrix
from petsc4py import PETSc

from forming import compat
from forming.errors import InputError


class CompiledJacobian:
    """Assembles a one-body model's Jacobian from compiled element matrices and forms.

    Args:
        A: The solver's matrix (its pattern is replaced by the element matrices').
        tangent: The element matrices of the model's only body
            (:class:`~forming.bodies.hextangent.HexTangent`).
        rest: The compiled forms of every other Jacobian term, or None.
        bcs: The model's Dirichlet conditions (on the body's space).
    """

    def __init__(self, A: PETSc.Mat, tangent, rest: fem.Form | None, bcs: list):
        self.tangent = tangent
        self.rest = rest
        self.bcs = bcs
        imap = tangent.body.V.dofmap.index_map
        n_nodes = imap.size_local + imap.num_ghosts
        self._n_dofs = 3 * n_nodes
        self._n_owned = 3 * imap.size_local
        glob = imap.local_to_global(np.arange(n_nodes, dtype=np.int32))
        gdofs = (3 * glob[:, None] + np.arange(3)).ravel()
        ed = gdofs[self.tangent.dofs]  # (cells, 24) global dofs
        rows = np.repeat(ed, 24, axis=1).ravel()
        cols = np.tile(ed, (1, 24)).ravel()
        # the element entries are summed into the matrix's distinct entries in the
        # compiled loop: PETSc then copies instead of summing 2 to 8 values per entry
        size = A.getSize()[1]
        keys, self._slots = np.unique(rows * size + cols, return_inverse=True)
        self._n_element = keys.size
        # every owned dof's diagonal: 1 where prescribed (an owned row of the rank)
        diag = gdofs[: self._n_owned]
        coo_i = np.concatenate([keys // size, diag]).astype(PETSc.IntType)
        coo_j = np.concatenate([keys % size, diag]).astype(PETSc.IntType)
        A.setPreallocationCOO(coo_i, coo_j)
        self.values = np.zeros(coo_i.size, dtype=PETSc.ScalarType)
        self._keep = np.ones(self._n_dofs)

    def _free(self) -> np.ndarray:
        """1 at every free dof of the body (owned and ghost), 0 at a prescribed one."""
        keep = self._keep
        keep[:] = 1.0
        for bc in self.bcs:
            dofs, _ = bc.dof_indices()
            keep[dofs] = 0.0
        return keep

    def assemble(self, A: PETSc.Mat) -> None:
        """The Jacobian at the body's displacement and last point evaluation into ``A``."""
        keep = self._free()
        self.tangent.matrices(keep, self._slots, self.values[: self._n_element])
        self.values[self._n_element:] = 1.0 - keep[: self._n_owned]
        A.setValuesCOO(self.values, addv=PETSc.InsertMode.INSERT_VALUES)
        if self.rest is not None:
            assemble_matrix(A, self.rest, self.bcs, diag=1.0)
        A.assemble()


def compiled_jacobian(model, A: PETSc.Mat, choice: str) -> CompiledJacobian | None:
    """The Jacobian from compiled element matrices where they apply, else None.

    Args:
        model: The model (:class:`~forming.model.Model`).
        A: The solver's matrix.
        choice: ``newton.jacobian``: ``auto``, ``compiled`` or ``forms``.

    Raises:
        InputError: ``compiled`` for a model it does not apply to.
    """
    if choice == "forms":
        return None
    bodies = list(model.bodies.values())
    tangent = (bodies[0].compiled_tangent()
               if len(bodies) == 1 and not model.sliding else None)
    if tangent is None:
        if choice == "compiled":
            raise InputError("newton.jacobian", "compiled element matrices need one body of "
                             "P1 hexahedra with 8 points and no sliding contact")
        return None
    rest = model.jacobians(own=False)[0][0]
    if rest is not None:
        rest = fem.form(rest, entity_maps=model.entity_maps or None,
                        jit_options=compat.SOLVE_JIT_OPTIONS)
    return CompiledJacobian(A, tangent, rest, model.dirichlet.bcs)
