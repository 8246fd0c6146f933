"""Parameter studies: one case run over combinations of parameters, tabulated and judged.

``forming study CASE --vary KEY=V1,V2,... --metric NAME --out DIR`` runs the case once
per combination of the varied values (the Cartesian product of every ``--vary``), each in
its own folder under ``DIR/runs`` with its usual outputs, as separate processes (``--jobs``
at a time, each on ``--ranks`` ranks). A run already in ``DIR`` with the same settings is
not run again, so a study can be resumed or extended by a level. A run that fails is a row
with its status. The table, the convergence judgement and the plots are
:mod:`forming.study_report`'s.

With ``--drape`` each run is the kinematic drape onto the case's tool instead
(``forming drape CASE``, which writes a ``summary.json`` of the same shape); its own
settings vary as ``drape.spacing=8,4,2`` (``drape.angle``, ``drape.size``, ``drape.tool``).

Values: ``KEY=1,2,4`` varies a scalar; a value that holds commas itself (a tuple such as
``cells``) separates its levels by ``:`` (``cells=8,8,2:12,12,3:16,16,4``).
"""

from __future__ import annotations

import itertools
import json
import logging
import os
import re
import subprocess
import sys
import time
import typing
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from forming.case import SOLVER_PREFIXES, find_case, load_case
from forming.errors import InputError

log = logging.getLogger("forming.study")

FIXED_COLUMNS = ("status", "wall_s", "steps", "newton_iterations", "unknowns", "peak_rss_mb")


@dataclass(frozen=True)
class Vary:
    """One varied parameter and its levels (as given on the command line)."""

    key: str
    values: tuple[str, ...]

    @classmethod
    def parse(cls, text: str, sequences: frozenset[str] = frozenset()) -> Vary:
        """``KEY=V1,V2,...``, or ``KEY=A:B:...`` when a level holds commas.

        Args:
            text: The command-line text.
            sequences: Parameters whose values are tuples: their levels are separated by
                ``:`` only, so ``cells=12,12,3`` is one level.

        Raises:
            InputError: No ``=``, an empty key, or fewer than one level.
        """
        key, sep, rest = text.partition("=")
        key = key.strip()
        if not sep or not key or not rest.strip():
            raise InputError("--vary", f"expected KEY=V1,V2,... got {text!r}")
        split = ":" if ":" in rest or key in sequences else ","
        values = tuple(v.strip() for v in rest.split(split))
        if any(not v for v in values):
            raise InputError("--vary", f"an empty level in {text!r}")
        if len(set(values)) != len(values):
            raise InputError("--vary", f"a level given twice in {text!r}")
        return cls(key, values)


@dataclass(frozen=True)
class Study:
    """What to run and what to record.

    Attributes:
        case: The case's name (``forming list``).
        varies: The varied parameters; every combination is one run.
        out: The study's folder.
        sets: ``KEY=VALUE`` settings every run shares.
        metrics: ``summary.json`` metrics to tabulate, judge and plot.
        reference: What the error is measured against: a number, ``"finest"`` (the run
            with the most unknowns, or the last level) or ``"extrapolated"`` (Richardson,
            falling back to the finest when the levels do not allow it).
        jobs: Runs at a time.
        ranks: MPI ranks per run.
        drape: Each run is ``forming drape`` (one process) instead of the case's run.
    """

    case: str
    varies: tuple[Vary, ...]
    out: Path
    sets: tuple[str, ...] = ()
    metrics: tuple[str, ...] = ()
    reference: str = "extrapolated"
    jobs: int = 1
    ranks: int = 1
    drape: bool = False

    def __post_init__(self) -> None:
        find_case(self.case)  # raises InputError naming the known cases
        if not self.varies:
            raise InputError("--vary", "give at least one KEY=V1,V2,...")
        keys = [v.key for v in self.varies]
        if len(set(keys)) != len(keys):
            raise InputError("--vary", f"a parameter varied twice: {keys}")
        fixed = {s.partition("=")[0].strip() for s in self.sets}
        if fixed & set(keys):
            raise InputError("--set", f"{sorted(fixed & set(keys))} both set and varied")
        known = set(load_case(self.case).Params.__dataclass_fields__) | {"solver"}
        if self.drape:
            from forming.drape_case import DRAPE_SETTINGS

            known |= {f"drape.{k}" for k in DRAPE_SETTINGS}
        solver_keys = () if self.drape else SOLVER_PREFIXES  # a drape has no solver
        for key in keys:
            if key in known or key.startswith(solver_keys):
                continue
            hint = (" (drape settings need --drape)" if key.startswith("drape.") and not self.drape
                    else "")
            raise InputError("--vary", f"{self.case} has no parameter {key!r}{hint}")
        if self.drape and self.ranks != 1:
            raise InputError("--ranks", "a drape runs on one process")
        if self.jobs < 1 or self.ranks < 1:
            raise InputError("--jobs/--ranks", "must be at least 1")
        if self.reference not in ("finest", "extrapolated"):
            try:
                float(self.reference)
            except ValueError:
                raise InputError("--reference", "a number, 'finest' or 'extrapolated', "
                                 f"got {self.reference!r}") from None

    def combinations(self) -> list[dict[str, str]]:
        """Every combination of the varied levels, in the order given."""
        keys = [v.key for v in self.varies]
        return [dict(zip(keys, c, strict=True))
                for c in itertools.product(*(v.values for v in self.varies))]


@dataclass(frozen=True)
class Row:
    """One run of a study: its varied values and what it measured."""

    values: dict[str, str]
    folder: Path
    status: str
    reason: str = ""
    wall_s: float = float("nan")
    steps: int = 0
    newton_iterations: int = 0
    unknowns: int = 0
    peak_rss_mb: float = float("nan")
    metrics: dict[str, float] = field(default_factory=dict)
    reused: bool = False

    @classmethod
    def from_summary(cls, values: dict[str, str], folder: Path, summary: dict,
                     reused: bool = False) -> Row:
        """The row of a run that wrote its ``summary.json``."""
        timing = summary.get("timing") or {}
        return cls(
            values, folder, summary.get("status", "unknown"), summary.get("reason") or "",
            float(timing.get("wall_s", float("nan"))), int(timing.get("steps") or 0),
            int(timing.get("newton_iterations", timing.get("work")) or 0),
            int((summary.get("mesh") or {}).get("dofs") or 0),
            float(timing.get("peak_rss_mb", float("nan"))),
            {k: float(v) for k, v in (summary.get("metrics") or {}).items()
             if isinstance(v, (int, float)) and not isinstance(v, bool)},
            reused)


def folder_name(values: dict[str, str]) -> str:
    """A run's folder: its varied values, filesystem-safe (``cells-8-8-2_max_step-0.01``)."""
    parts = [f"{k}-{v}" for k, v in values.items()]
    return re.sub(r"[^A-Za-z0-9._-]+", "-", "_".join(parts))


def _assignments(study: Study, values: dict[str, str]) -> list[str]:
    return list(study.sets) + [f"{k}={v}" for k, v in values.items()]


def _summary(folder: Path, assignments: list[str]) -> dict | None:
    """The ``summary.json`` in ``folder`` if it is of a run with these settings."""
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    same = sorted(summary.get("assignments") or []) == sorted(assignments)
    return summary if same else None


def command(study: Study, folder: Path, assignments: list[str]) -> list[str]:
    """The command line of one run (``mpirun -n R`` in front with several ranks)."""
    run = ["-m", "forming.cli", "drape", study.case] if study.drape else [
        str(find_case(study.case))]
    cmd = [sys.executable, *run, "--out", str(folder), "--quiet"]
    for a in assignments:
        cmd += ["--set", a]
    if study.ranks > 1:
        cmd = [str(Path(sys.executable).parent / "mpirun"), "-n", str(study.ranks)] + cmd
    return cmd


def run_one(study: Study, values: dict[str, str]) -> Row:
    """Run (or reuse) one combination; never raises for a failed run."""
    folder = study.out / "runs" / folder_name(values)
    assignments = _assignments(study, values)
    summary = _summary(folder, assignments)
    if summary is not None and summary.get("status") in ("completed", "failed"):
        log.info("study: %s reused (%s)", folder.name, summary["status"])
        return Row.from_summary(values, folder, summary, reused=True)
    folder.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    log.info("study: %s started", folder.name)
    with open(study.out / "runs" / f"{folder.name}.log", "w") as stream:
        proc = subprocess.run(command(study, folder, assignments), env=env, stdout=stream,
                              stderr=subprocess.STDOUT, text=True)
    # (a run refused before it cleared its folder leaves an older summary there)
    summary = _summary(folder, assignments)
    row = (Row.from_summary(values, folder, summary) if summary is not None else Row(
        values, folder, "error", f"exit code {proc.returncode}, no summary.json of this "
        f"run (see {folder.name}.log)", time.perf_counter() - t0))
    log.info("study: %s %s in %.1f s", folder.name, row.status, time.perf_counter() - t0)
    return row


def run_study(study: Study) -> list[Row]:
    """Every combination, ``jobs`` at a time, in the order of :meth:`Study.combinations`."""
    study.out.mkdir(parents=True, exist_ok=True)
    combos = study.combinations()
    with ThreadPoolExecutor(max_workers=study.jobs) as pool:
        return list(pool.map(lambda v: run_one(study, v), combos))


def tuple_parameters(case: str) -> frozenset[str]:
    """The case's parameters whose values are tuples (``cells``)."""
    hints = typing.get_type_hints(load_case(case).Params)
    return frozenset(k for k, t in hints.items() if typing.get_origin(t) is tuple)


def parse_study(case: str, vary: Sequence[str], out: Path, sets: Sequence[str] = (),
                metrics: Sequence[str] = (), reference: str = "extrapolated",
                jobs: int = 1, ranks: int = 1, drape: bool = False) -> Study:
    """A :class:`Study` from command-line strings."""
    find_case(case)  # raises InputError naming the known cases
    sequences = tuple_parameters(case)
    return Study(case, tuple(Vary.parse(v, sequences) for v in vary), Path(out), tuple(sets),
                 tuple(metrics), reference, jobs, ranks, drape)
