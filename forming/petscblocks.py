"""Many dense blocks added to a PETSc matrix in one compiled call.

A contact's Jacobian is a block per pair (27 x 27 for a node on a quadrilateral, more
with the area transfer): thousands per evaluation. Added from Python, one
``Mat.setValues`` each, the calls cost more than computing the blocks (the demonstrator
spent a fifth of its Newton iterations there). Here a numba loop calls PETSc's
``MatSetValues`` itself, through the library DOLFINx was built against (as DOLFINx's own
``numba_utils`` does for ``MatSetValuesLocal``).
"""

from __future__ import annotations

import llvmlite.binding
import numba
import numpy as np
from dolfinx.fem.petsc import get_petsc_lib
from numba.core import types
from numba.core.typing import signature
from petsc4py import PETSc

llvmlite.binding.load_library_permanently(str(get_petsc_lib()))

_INT = numba.from_dtype(PETSc.IntType)
_SCALAR = numba.from_dtype(PETSc.ScalarType)
_MatSetValues = types.ExternalFunction("MatSetValues", signature(
    types.intc, types.uintp, _INT, types.CPointer(_INT), _INT, types.CPointer(_INT),
    types.CPointer(_SCALAR), types.intc))


@numba.njit(cache=True)
def _add(handle, blocks, rows, cols, values, mode):
    """``MatSetValues`` for every block; PETSc's error code of the first failure, or 0."""
    for k in range(blocks.shape[0]):
        r, m, c, n, v = blocks[k, 0], blocks[k, 1], blocks[k, 2], blocks[k, 3], blocks[k, 4]
        err = _MatSetValues(handle, m, rows[r:r + m].ctypes, n, cols[c:c + n].ctypes,
                            values[v:v + m * n].ctypes, mode)
        if err != 0:
            return err
    return 0


def add_blocks(A: PETSc.Mat, blocks: np.ndarray, rows: np.ndarray, cols: np.ndarray,
               values: np.ndarray) -> None:
    """Add dense blocks to ``A`` (global indices; negative ones are skipped, as PETSc does).

    Args:
        A: The matrix (not assembled afterwards: the caller does).
        blocks: One row per block: first row index, rows, first column index, columns,
            first value (row-major ``rows x columns`` values), offsets into the arrays.
        rows: Global row indices.
        cols: Global column indices.
        values: The blocks' values.

    Raises:
        PETSc.Error: PETSc refused a block (an entry outside the matrix's pattern, where
            that is an error).
    """
    err = _add(A.handle, np.ascontiguousarray(blocks, dtype=np.int64),
               np.ascontiguousarray(rows, dtype=PETSc.IntType),
               np.ascontiguousarray(cols, dtype=PETSc.IntType),
               np.ascontiguousarray(values, dtype=PETSc.ScalarType),
               int(PETSc.InsertMode.ADD_VALUES))
    if err:
        raise PETSc.Error(err)
