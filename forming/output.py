"""The output contract: summary.json, history.csv, ParaView fields and PNG plots.

Only rank 0 writes files; every collective happens on all ranks before that.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import re
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat
from forming.errors import InputError

PICTURES_ENV = "FORMING_PICTURES"


def pictures_wanted() -> bool:
    """Whether a run draws its case's pictures: ``FORMING_PICTURES`` 1 (the default) or 0.

    The 3D views and sections a case draws when a run ends take about a second each (an
    off-screen render); a batch of runs, or the test suite, may leave them out
    (``--no-pictures``). The plots of the history are drawn either way.

    Raises:
        InputError: Another value.
    """
    value = os.environ.get(PICTURES_ENV, "1").strip().lower()
    if value in ("1", "true", "yes", "on"):
        return True
    if value in ("0", "false", "no", "off"):
        return False
    raise InputError(PICTURES_ENV, f"must be 1 or 0, got {value!r}")


@contextlib.contextmanager
def _replacing(path: Path):
    """Write a text file through a temporary file renamed over it.

    A run killed while writing leaves the previous version whole, never a truncated file.
    """
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", newline="") as fh:
        yield fh
    os.replace(tmp, path)


def json_safe(value):
    """JSON-safe copy (NaN/inf as null, numpy scalars as Python numbers)."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


RUN_FILES = ("summary.json", "summary.json.tmp", "history.csv", "history.csv.tmp",
             "final_shape.npz", "*.png", "*.bp", "*.pvd", "*.vtkhdf", "tools",
             "checkpoint.npz", "checkpoint.npz.tmp")
"""What a run writes into its folder (glob patterns); a rerun removes these first."""


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()


def prepare_output_folder(out: Path, comm: MPI.Comm) -> None:
    """Make ``out`` ready for a run (collective).

    A missing folder is created. A folder that holds an earlier run (its
    ``summary.json``) is cleared of that run's files (:data:`RUN_FILES`), so that no
    file of another run stays beside the new one; other files are left alone. A
    non-empty folder without a run in it is refused, as is a path that is a file.

    Raises:
        InputError: On every rank, naming the folder and the problem.
    """
    problem = None
    if comm.rank == 0:
        try:
            if out.exists() and not out.is_dir():
                problem = f"{out} is a file, not a folder"
            elif out.is_dir() and any(out.iterdir()):
                if not (out / "summary.json").is_file():
                    problem = (f"{out} is not empty and holds no earlier run (no summary.json):"
                               " choose an empty or new folder")
                else:
                    for pattern in RUN_FILES:
                        for path in out.glob(pattern):
                            _remove(path)
            else:
                out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            problem = f"{out}: {exc.strerror or exc}"
    problem = comm.bcast(problem, root=0)
    if problem is not None:
        raise InputError("--out", problem)


def keep_field_series(out: Path, comm: MPI.Comm) -> list[str]:
    """Rename the field series of an earlier run in ``out`` to the next free ``partN``.

    A restarted run writes its fields afresh (an ADIOS2 VTX series cannot be appended
    to); the series of the run it continues stay beside them: ``displacement.bp`` becomes
    ``displacement.part1.bp`` (``part2`` after a second restart), likewise
    ``tool_<name>.pvd``.

    Returns:
        The new names (collective: every rank gets them).

    Raises:
        OSError: On every rank, when a file could not be renamed.
    """
    renamed, problem = [], None
    if comm.rank == 0:
        current = [p for p in (*out.glob("*.bp"), *out.glob("tool_*.pvd"))
                   if ".part" not in p.name]
        used = [int(m.group(1)) for p in out.iterdir()
                if (m := re.search(r"\.part(\d+)\.(bp|pvd)$", p.name))]
        part = max(used, default=0) + 1
        try:
            for p in sorted(current):
                new = p.with_name(f"{p.stem}.part{part}{p.suffix}")
                p.rename(new)
                renamed.append(new.name)
        except OSError as exc:
            problem = f"{out}: {exc.strerror or exc}"
    renamed, problem = comm.bcast((renamed, problem), root=0)
    if problem is not None:
        raise OSError(problem)
    return renamed


class Recorder:
    """Writes the run's history rows, fields and summary into ``out``.

    Args:
        out: Output folder (created).
        comm: Communicator of the run.
        resume: Continue the run in ``out`` (a restart): nothing is cleared, and the
            earlier field series are kept under new names (:func:`keep_field_series`).
    """

    def __init__(self, out: Path, comm: MPI.Comm, resume: bool = False):
        self.out = Path(out)
        self.comm = comm
        self.rows: list[dict[str, float]] = []
        self.earlier_fields: list[str] = []
        if resume:
            self.earlier_fields = keep_field_series(self.out, comm)
        else:
            prepare_output_folder(self.out, comm)
        self._writers: list = []
        self._stems: list[str] = []

    def add_fields(self, name: str, functions: list[fem.Function]) -> None:
        """Write ``functions`` (one element type) to ``<name>.bp`` at every output."""
        self._writers.append(compat.vtx_writer(self.comm, self.out / f"{name}.bp", functions))
        self._stems.append(name)

    def field_stems(self) -> list[str]:
        """Names of the ``.bp`` files written."""
        return list(self._stems)

    def write_fields(self, t: float) -> None:
        """Write all registered fields at load parameter ``t``."""
        for w in self._writers:
            w.write(t)

    def record(self, row: dict[str, float]) -> None:
        """Append a history row (same keys every step) and rewrite history.csv."""
        self.rows.append(row)
        self._write_history()

    def truncate(self, n_rows: int) -> None:
        """Keep the first ``n_rows`` rows (a run restored to an earlier state)."""
        del self.rows[n_rows:]
        self._write_history()

    def _write_history(self) -> None:
        if self.comm.rank == 0 and self.rows:
            keys = list(self.rows[0].keys())
            with _replacing(self.out / "history.csv") as fh:
                w = csv.DictWriter(fh, fieldnames=keys)
                w.writeheader()
                w.writerows(self.rows)

    def column(self, key: str) -> np.ndarray:
        """One history column as an array."""
        return np.array([r[key] for r in self.rows], dtype=float)

    def write_summary(self, summary: dict) -> Path:
        """Write ``summary.json`` (rank 0)."""
        path = self.out / "summary.json"
        if self.comm.rank == 0:
            with _replacing(path) as fh:
                fh.write(json.dumps(json_safe(summary), indent=2) + "\n")
        return path

    def close(self) -> None:
        """Close the field writers."""
        for w in self._writers:
            w.close()
        self._writers = []


def plot_curves(path: Path, series: list[tuple[np.ndarray, np.ndarray, str, str]],
                xlabel: str, ylabel: str, title: str, logx: bool = False,
                logy: bool = False, notes: Sequence[tuple[float, float, str]] = ()) -> Path:
    """Line plot of ``(x, y, label, style)`` series to a PNG (call on rank 0).

    A label ``"_"`` keeps a series out of the legend; ``logx``/``logy``: log axes;
    ``notes``: ``(x, y, text)`` written next to points (a study's levels).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    for x, y, label, style in series:
        ax.plot(x, y, style, label=label, markersize=3)
    for i, (x, y, text) in enumerate(notes):  # alternate above and below: close points
        ax.annotate(text, (x, y), fontsize=7, textcoords="offset points",
                    xytext=(4, 4 if i % 2 == 0 else -10))
    if logx:
        ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def write_final_shape(path: Path, bodies: dict, comm: MPI.Comm) -> Path:
    """Write every body's nodes, displacements and cell-wise results to an ``.npz``.

    Keys ``<body>_X`` and ``<body>_u`` hold (n, 3) arrays of the owned dofs of all ranks,
    sorted by reference coordinates so that two runs of the same mesh line up row by row
    whatever the partition (``forming compare`` reads this file). A body with cell-wise
    results (:meth:`~forming.bodies.base.DeformableBody.cell_fields`, e.g. a fabric's
    shear angle) adds, per owned cell sorted by reference centroid: ``<body>_cell_X`` and
    ``<body>_cell_x`` (reference and current centroid, the mean of its nodes, (m, 3)),
    ``<body>_cell_volume`` (reference volume, the Jacobian at the centre: exact for
    parallelepipeds) and ``<body>_cell_<field>`` (m,).

    Args:
        path: File to write (on rank 0).
        bodies: Model bodies by name (each with a vector function space ``V`` and ``u``).
        comm: Communicator of the run (collective).
    """
    arrays: dict[str, np.ndarray] = {}

    def gathered(columns: dict[str, np.ndarray]) -> None:
        """All ranks' rows into ``arrays``, sorted by the first column (coordinates)."""
        every = comm.gather(columns, root=0)
        if comm.rank == 0:
            cols = {k: np.concatenate([p[k] for p in every]) for k in columns}
            order = np.lexsort(np.round(next(iter(cols.values())), 9).T[::-1])
            arrays.update({k: v[order] for k, v in cols.items()})

    for name, body in bodies.items():
        n = body.V.dofmap.index_map.size_local
        bs = body.V.dofmap.index_map_bs
        X = body.V.tabulate_dof_coordinates()
        u = body.u.x.array.reshape(-1, bs)
        gathered({f"{name}_X": X[:n], f"{name}_u": u[:n]})
        fields = body.cell_fields()
        if fields:
            dofs = body.V.dofmap.list[body.cells[: body.n_local_cells]]
            Xc, xc = X[dofs], (X + u)[dofs]
            gathered({f"{name}_cell_X": Xc.mean(axis=1), f"{name}_cell_x": xc.mean(axis=1),
                      f"{name}_cell_volume": hex_volumes(Xc)}
                     | {f"{name}_cell_{k}": v for k, v in fields.items()})
    if comm.rank == 0:
        np.savez_compressed(path, **arrays)
    return path


def hex_volumes(corners: np.ndarray) -> np.ndarray:
    """Volumes of hexahedra from their 8 corners in DOLFINx order, (m, 8, 3) -> (m,).

    The Jacobian determinant at the centre of the unit cube (corner k at
    ``(k & 1, k >> 1 & 1, k >> 2 & 1)``): exact for parallelepipeds.
    """
    c = corners
    j = np.stack([(c[:, 1::2] - c[:, 0::2]).mean(axis=1),
                  (c[:, [2, 3, 6, 7]] - c[:, [0, 1, 4, 5]]).mean(axis=1),
                  (c[:, 4:] - c[:, :4]).mean(axis=1)], axis=2)
    return np.abs(np.linalg.det(j))


class FieldOutput:
    """ParaView output of a model: displacements, body fields and tool surfaces.

    Args:
        model: The model (:class:`~forming.model.Model`).
        recorder: The run's recorder (owns the writers).
    """

    def __init__(self, model, recorder: Recorder):
        self.model = model
        self.recorder = recorder
        several = len(model.bodies) > 1
        for name, body in model.bodies.items():
            recorder.add_fields(f"displacement_{name}" if several else "displacement", [body.u])
        self._tools = None
        if model.scene.tools:
            # collective (reductions over ranks): on every rank, outside the rank-0 branch
            bounds, resolution = model.tool_bounds(), model.tool_resolution()
            if model.comm.rank == 0:
                from forming.contact.render import ToolSeries

                self._tools = ToolSeries(recorder.out,
                                         [(t.name, t.shape) for t in model.scene.tools],
                                         bounds, resolution)
        for name, body in model.bodies.items():
            for stem, funcs in body.output_fields().items():
                recorder.add_fields(f"{stem}_{name}" if several else stem, funcs)

    def write(self, step: int, t: float) -> None:
        """Bring the body fields up to date and write every field at load parameter ``t``."""
        for body in self.model.bodies.values():
            body.update_output()
        self.recorder.write_fields(t)
        if self._tools is not None:
            self._tools.write(step, t, {tl.name: tl.offset(t) for tl in self.model.scene.tools})

    def outputs(self) -> list[str]:
        """File names written: field series and tool surfaces."""
        return ([f"{stem}.bp" for stem in self.recorder.field_stems()]
                + [f"tool_{t.name}.pvd" for t in self.model.scene.tools])
