"""Read back the ParaView fields a run writes (ADIOS2 VTX ``.bp`` series).

Every run writes its fields as ADIOS2 VTX files (``displacement.bp``,
``plastic_strain.bp``, ...), which ParaView opens with its ADIOS2 VTX reader. This module
reads them in Python with the ``adios2`` package: the reference coordinates of the
nodes, a field's values and the load parameter of each output step, with the blocks of
every rank joined and their shared (ghost) nodes counted once.

    series = FieldSeries("results/hemisphere/displacement.bp")
    X, u = series.points(), series.values("u")      # the last step
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forming.errors import InputError

_MESH_VARIABLES = {"NumberOfEntities", "NumberOfNodes", "connectivity", "geometry", "step",
                   "types", "vtkGhostType", "vtkOriginalPointIds"}


class FieldSeries:
    """The output steps of one ``.bp`` field file.

    Args:
        path: The ``.bp`` folder.

    Raises:
        InputError: The path is not a readable ADIOS2 file.
    """

    def __init__(self, path: Path | str):
        import adios2

        self.path = Path(path)
        if not self.path.exists():
            raise InputError("fields", f"{self.path} does not exist")
        try:
            with adios2.FileReader(str(self.path)) as f:
                self._variables = f.available_variables()
                self.times = np.atleast_1d(f.read("step", step_selection=[
                    0, int(self._variables["step"]["AvailableStepsCount"])])).astype(float)
        except (RuntimeError, ValueError, KeyError) as exc:
            raise InputError("fields", f"{self.path} is not a readable VTX file: {exc}") from exc

    @property
    def names(self) -> list[str]:
        """Names of the fields in the file."""
        return sorted(set(self._variables) - _MESH_VARIABLES)

    def _read(self, name: str, step: int) -> tuple[np.ndarray, np.ndarray]:
        """A variable's blocks joined, and the original node ids of every row."""
        import adios2

        step = step % len(self.times)
        with adios2.FileReader(str(self.path)) as f:
            # a rank that holds none of a body's nodes writes an empty block, which
            # adios2 cannot read: skip it
            blocks = [int(b["BlockID"]) for b in f.all_blocks_info(name)[step]
                      if 0 not in _count(b)]
            sel = [step, 1]
            parts = [np.atleast_2d(f.read(name, step_selection=sel, block_id=b).T).T
                     for b in blocks]
            ids = [f.read("vtkOriginalPointIds", step_selection=sel, block_id=b).ravel()
                   for b in blocks]
        return np.concatenate(parts), np.concatenate(ids)

    def points(self, step: int = -1) -> np.ndarray:
        """Reference coordinates of the nodes, (n, 3), ordered by their original id."""
        x, ids = self._read("geometry", step)
        _, first = np.unique(ids, return_index=True)
        return x[first]

    def values(self, name: str, step: int = -1) -> np.ndarray:
        """A nodal field at an output step (default the last), rows as :meth:`points`.

        Raises:
            InputError: No such field.
        """
        if name not in self.names:
            raise InputError("fields", f"{self.path} has no field {name!r}; it has "
                             f"{self.names}")
        v, ids = self._read(name, step)
        _, first = np.unique(ids, return_index=True)
        return v[first]


def _count(block: dict) -> tuple[int, ...]:
    """The extents of one block of a variable, from adios2's block info."""
    return tuple(int(c) for c in block["Count"].split(",") if c.strip())
