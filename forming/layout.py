"""Where each body's degrees of freedom sit in the implicit solver's vectors and matrix.

One body: its own vector. Several: one monolithic vector (DOLFINx's ``kind="mpi"``)
whose owned part on a rank is the rank's owned dofs of the first body, then of the
second, and so on. A constraint assembled outside the forms (finite sliding between two
bodies) adds into those objects by global index.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI


class Layout:
    """Global indices of every body's dofs, and which are prescribed.

    Args:
        bodies: The model's bodies in block order.
        comm: Their communicator.
    """

    def __init__(self, bodies: dict, comm: MPI.Comm):
        self._bodies = bodies
        sizes = [b.V.dofmap.index_map.size_local * b.V.dofmap.bs for b in bodies.values()]
        self.local_size = sum(sizes)  # this rank's owned dofs of every body
        offset = comm.exscan(sum(sizes)) or 0
        self._index: dict[str, np.ndarray] = {}
        self._local_offset: dict[str, int] = {}
        start = offset
        for (name, body), size in zip(bodies.items(), sizes, strict=True):
            self._local_offset[name] = start - offset
            f = fem.Function(body.V)
            f.x.array[:size] = start + np.arange(size)
            f.x.scatter_forward()  # ghosts take their owner's index
            self._index[name] = np.rint(f.x.array).astype(np.int64)
            start += size
        self._fixed: dict[str, np.ndarray] = {}

    def local_offset(self, body: str) -> int:
        """Where ``body``'s owned dofs start within this rank's owned part of a vector."""
        return self._local_offset[body]

    def index(self, body: str) -> np.ndarray:
        """Global index of each local dof (owned and ghost) of ``body``."""
        return self._index[body]

    def set_prescribed(self, bcs: list[fem.DirichletBC], bc_bodies: list[str]) -> None:
        """Record the prescribed dofs (rows and columns a constraint must leave alone)."""
        for name, body in self._bodies.items():
            mask = np.zeros(body.u.x.array.size, dtype=bool)
            for bc, owner in zip(bcs, bc_bodies, strict=True):
                if owner == name:
                    mask[bc.dof_indices()[0]] = True
            self._fixed[name] = mask

    def prescribed(self, body: str) -> np.ndarray:
        """Whether each local dof (owned and ghost) of ``body`` is prescribed."""
        return self._fixed[body]
