"""Checkpoints on disk: a simulation's in-memory state made persistent, for ``--restart``.

The state written is exactly what :meth:`forming.simulation.Simulation.checkpoint` holds
in memory (the model's and the solver's snapshots, the stepper, the history so far);
the objects that own it say where each of its arrays lives (``snapshot_layout``: a
:class:`~forming.domain.CellLayout` per array distributed over a mesh). Such an array is
stored cell by cell, each row keyed by the original (mesh-generator) index of its
scene-mesh cell, so that a run on another partition or number of ranks finds the rows
of its own cells, owned and ghost. Everything else (load parameters, counters, energies,
a tool's offset) is the same on every rank and is stored once.

One file, ``OUT/checkpoint.npz`` (NumPy's uncompressed zip of arrays):

* ``meta``: JSON text: format version, case, ``--set`` assignments, step, load parameter,
  ranks, why it was written, the stepper's state, the history rows so far, and the
  snapshot's structure, in which each array is a reference ``{"$cells": key}`` (per
  cell) or ``{"$array": key}`` (global);
* ``<key>.keys`` and ``<key>.rows`` for each per-cell array: the sorted cell keys and one
  row of values per cell (the cell's blocks side by side, in the cell's local order);
  ``<key>`` for each global array;
* ``mesh.x``: the node coordinates of every cell of the scene mesh (per-cell, as above):
  a restart compares them with its own mesh and refuses a different one.

Rank 0 gathers the rows and writes the file to ``checkpoint.npz.tmp``, then renames it
over the previous one, so a run killed while writing keeps its previous checkpoint
whole. Every rank reads the file on restart.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from forming.domain import CellLayout
from forming.errors import InputError

FILE_NAME = "checkpoint.npz"
FORMAT = 1
MESH_KEY = "mesh.x"
_MESH_TOLERANCE = 1e-9  # relative to the mesh's extent


def checkpoint_path(folder: Path | str) -> Path:
    """The checkpoint file of a run folder."""
    return Path(folder) / FILE_NAME


def geometry_layout(msh) -> CellLayout:
    """Layout of a scene mesh's node coordinates, cell by cell (the mesh check)."""
    imap = msh.topology.index_map(3)
    n_cells = imap.size_local + imap.num_ghosts
    keys = np.asarray(msh.topology.original_cell_index, dtype=np.int64)[:n_cells]
    return CellLayout(keys, imap.size_local, msh.geometry.dofmaps[0][:n_cells], 3,
                      msh.geometry.x.shape)


# -- writing ------------------------------------------------------------------------------
@dataclass
class _Encoded:
    """Arrays found while encoding a snapshot: per-cell (with layouts) and global."""

    cells: list[tuple[str, np.ndarray, CellLayout]]
    arrays: dict[str, np.ndarray]


def _encode(value, layout, key: str, found: _Encoded):
    """The JSON structure of ``value``, with references in place of its arrays."""
    if value is None:
        return None
    if isinstance(layout, CellLayout):
        found.cells.append((key, np.asarray(value), layout))
        return {"$cells": key}
    if isinstance(value, np.ndarray):
        found.arrays[key] = value.copy()
        return {"$array": key}
    if isinstance(value, dict):
        return {"$dict": {str(k): _encode(v, None if layout is None else layout[k],
                                          f"{key}.{k}", found) for k, v in value.items()}}
    if isinstance(value, list | tuple):
        return {"$list": [_encode(v, None if layout is None else layout[i], f"{key}.{i}",
                                  found) for i, v in enumerate(value)]}
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bool | int | float | str):
        return value
    raise TypeError(f"checkpoint: cannot store {type(value).__name__} at {key}")


def _gathered(comm: MPI.Comm, value: np.ndarray, layout: CellLayout
              ) -> tuple[np.ndarray, np.ndarray] | None:
    """Every rank's owned rows on rank 0, sorted by cell key (None elsewhere)."""
    parts = comm.gather((layout.keys[: layout.n_owned], layout.rows(value)), root=0)
    if comm.rank != 0:
        return None
    keys = np.concatenate([p[0] for p in parts])
    rows = np.concatenate([p[1] for p in parts])
    order = np.argsort(keys, kind="stable")
    return keys[order], rows[order]


def save(path: Path, state: dict, layout: dict, meta: dict, msh) -> None:
    """Write a checkpoint (collective).

    Args:
        path: The file to write (``checkpoint.npz``).
        state: The snapshots to store (nested dicts, lists, tuples, arrays, numbers).
        layout: Their layouts, the same structure (see module docstring).
        meta: Further JSON-safe fields (case, step, history rows, ...).
        msh: The scene mesh (its coordinates are stored for the restart's check).

    Raises:
        OSError: On every rank, when rank 0 could not write the file.
    """
    comm = msh.comm
    found = _Encoded([], {})
    tree = _encode(state, layout, "state", found)
    found.cells.append((MESH_KEY, msh.geometry.x, geometry_layout(msh)))
    arrays: dict[str, np.ndarray] = {}
    for key, value, lay in found.cells:
        gathered = _gathered(comm, value, lay)
        if gathered is not None:
            arrays[f"{key}.keys"], arrays[f"{key}.rows"] = gathered
    problem = None
    if comm.rank == 0:
        arrays |= found.arrays
        text = json.dumps(meta | {"format": FORMAT, "state": tree})
        arrays["meta"] = np.array(text)
        tmp = path.with_name(path.name + ".tmp")
        try:
            with tmp.open("wb") as fh:
                np.savez(fh, **arrays)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        except OSError as exc:
            problem = f"{path}: {exc.strerror or exc}"
    problem = comm.bcast(problem, root=0)
    if problem is not None:
        raise OSError(problem)


# -- reading ------------------------------------------------------------------------------
def read_meta(path: Path) -> dict:
    """The metadata of a checkpoint file (local: no communication).

    Raises:
        InputError: The file is missing or is not a readable checkpoint.
    """
    if not path.is_file():
        raise InputError("--restart", f"{path.parent} holds no checkpoint ({path.name} is "
                         "missing): the run wrote none (checkpoint_every 0 and never "
                         "interrupted) or this is not a run folder")
    try:
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError("--restart", f"{path} is not a readable checkpoint "
                         f"({type(exc).__name__}: {exc})") from exc
    if meta.get("format") != FORMAT:
        raise InputError("--restart", f"{path} has checkpoint format {meta.get('format')!r};"
                         f" this version reads format {FORMAT}")
    return meta


class _Reader:
    """Rows of the per-cell arrays of an open checkpoint, for this rank's cells."""

    def __init__(self, z, path: Path):
        self.z = z
        self.path = path

    def rows(self, key: str, layout: CellLayout, where: str) -> np.ndarray:
        """The stored rows of every local cell of ``layout`` (owned and ghost)."""
        keys, rows = self.z[f"{key}.keys"], self.z[f"{key}.rows"]
        if rows.shape[1:] != (layout.width,):
            raise InputError("--restart", f"{self.path}: {where} holds {rows.shape[1:]} "
                             f"values per cell, this model {layout.width}: the checkpoint "
                             "was written with other parameters (element degree, "
                             "quadrature, material)")
        pos = np.minimum(np.searchsorted(keys, layout.keys), max(len(keys) - 1, 0))
        if len(layout.keys) and (len(keys) == 0 or np.any(keys[pos] != layout.keys)):
            raise InputError("--restart", f"{self.path}: {where} has no values for some "
                             "cells of this mesh: the checkpoint was written for another "
                             "mesh (other parameters)")
        return rows[pos]

    def decode(self, node, layout, where: str):
        """The value of an encoded node, per-cell arrays filled for this rank."""
        if node is None:
            return None
        if not isinstance(node, dict):
            return node
        mismatch = InputError("--restart", f"{self.path}: the stored state does not fit this "
                              f"model at {where}: the checkpoint was written with other "
                              "parameters or another version")
        if "$cells" in node:
            if not isinstance(layout, CellLayout):
                raise mismatch
            return layout.fill(self.rows(node["$cells"], layout, where))
        if "$array" in node:
            return np.array(self.z[node["$array"]])
        if "$dict" in node:
            items = node["$dict"]
            if layout is not None and set(layout) != set(items):
                raise mismatch
            return {k: self.decode(v, None if layout is None else layout[k], f"{where}.{k}")
                    for k, v in items.items()}
        items = node["$list"]
        if layout is not None and len(layout) != len(items):
            raise mismatch
        return [self.decode(v, None if layout is None else layout[i], f"{where}.{i}")
                for i, v in enumerate(items)]

    def check_mesh(self, msh) -> None:
        """Refuse a mesh whose cells are not where the checkpoint's were."""
        lay = geometry_layout(msh)
        stored = self.rows(MESH_KEY, lay, "the mesh")
        n_cells = len(lay.keys)
        here = msh.geometry.x[lay.entries].reshape(n_cells, -1)
        extent = float(np.ptp(msh.geometry.x, axis=0).max()) if msh.geometry.x.size else 1.0
        if n_cells and np.abs(stored - here).max() > _MESH_TOLERANCE * extent:
            raise InputError("--restart", f"{self.path}: the mesh differs from the "
                             "checkpoint's (nodes moved): it was written with other "
                             "parameters")


def load(path: Path, layout: dict, msh) -> tuple[dict, dict]:
    """Read a checkpoint onto this run's partition (collective).

    Args:
        path: The checkpoint file.
        layout: Layouts of the live objects' snapshots (the structure written).
        msh: The scene mesh of this run (checked against the stored one).

    Returns:
        The stored state, its per-cell arrays filled for this rank's cells, and the
        metadata.

    Raises:
        InputError: On every rank: the file is missing, unreadable, or does not fit
            this model (another case, other parameters, another mesh).
    """
    comm = msh.comm
    n_global = comm.allreduce(msh.topology.index_map(3).size_local, op=MPI.SUM)
    problem, state, meta = None, None, None
    try:  # nothing collective inside: a rank that fails must not leave others waiting
        meta = read_meta(path)
        with np.load(path) as z:
            reader = _Reader(z, path)
            if len(z[f"{MESH_KEY}.keys"]) != n_global:
                raise InputError("--restart", f"{path}: the checkpoint's mesh has "
                                 f"{len(z[f'{MESH_KEY}.keys'])} cells, this one {n_global}:"
                                 " it was written with other parameters")
            reader.check_mesh(msh)
            state = reader.decode(meta["state"], layout, "state")
    except InputError as exc:
        problem = str(exc)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
        problem = f"--restart: {path} is not a readable checkpoint ({type(exc).__name__}: {exc})"
    problems = [p for p in comm.allgather(problem) if p is not None]
    if problems:
        field, _, message = problems[0].partition(": ")
        raise InputError(field, message)
    return state, meta
