"""Assembled vectors: a vector form summed over ranks, with its ghost entries updated."""

from __future__ import annotations

import numpy as np
from dolfinx import fem, la  # noqa: I001

from forming import compat  # noqa: F401


def assembled(form: fem.Form, out: fem.Function | None = None) -> np.ndarray:
    """Assemble a vector form, sum shared entries and update ghosts."""
    vec = out.x if out is not None else la.vector(form.function_spaces[0].dofmap.index_map,
                                                   form.function_spaces[0].dofmap.index_map_bs)
    vec.array[:] = 0.0
    fem.assemble_vector(vec.array, form)
    vec.scatter_reverse(la.InsertMode.add)
    vec.scatter_forward()
    return vec.array if out is not None else vec.array.copy()
