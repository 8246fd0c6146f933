"""Helpers shared by the benchmarks: run a case as a process or a study, update docs."""

from __future__ import annotations

import json
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PERFORMANCE_MD = REPO / "docs" / "performance.md"


def revision(repo: Path = REPO) -> str:
    """The short commit of a checkout, ``+`` when its tracked files have changes ("?"
    outside git)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=repo, capture_output=True, text=True,
                              check=False).stdout.strip()

    return (git("rev-parse", "--short", "HEAD") or "?") + (
        "+" if git("status", "--porcelain", "--untracked-files=no") else "")


@dataclass(frozen=True)
class Run:
    """One run of a benchmark's study: its label, folder name and ``--set`` settings."""

    label: str
    slug: str
    sets: tuple[str, ...] = ()


def read_summary(folder: Path) -> dict:
    """A run's ``summary.json``, or {} where there is none (not run, or killed early)."""
    try:
        return json.loads((folder / "summary.json").read_text())
    except (OSError, json.JSONDecodeError):
        return {}


def final_shape(folder: Path) -> dict:
    """A run's ``final_shape.npz`` (each body's reference nodes and displacements)."""
    import numpy as np

    with np.load(folder / "final_shape.npz") as data:
        return {k: data[k] for k in data.files}


def run_case_process(case: str, out: Path, ranks: int = 1, sets: tuple[str, ...] = (),
                     env: dict[str, str] | None = None, allow_failure: bool = False,
                     repo: Path = REPO) -> dict:
    """Run ``cases/<case>.py`` in a fresh process; returns the summary plus ``process_s``.

    With ``allow_failure`` a run that stopped early (exit 1, summary written with
    ``status`` failed) is returned too; any other error raises. ``repo``: the source
    tree to run (another checkout, for before-and-after figures).
    """
    cmd = [sys.executable, f"cases/{case}.py", "--out", str(out)]
    for s in sets:
        cmd += ["--set", s]
    if ranks > 1:
        cmd = [str(Path(sys.executable).parent / "mpirun"), "-n", str(ranks)] + cmd
    full_env = dict(os.environ, OMP_NUM_THREADS="1", **(env or {}))
    t0 = time.perf_counter()
    if repo != REPO:
        full_env["PYTHONPATH"] = str(repo)
    proc = subprocess.run(cmd, cwd=repo, env=full_env, capture_output=True, text=True)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0 and not (allow_failure and proc.returncode == 1
                                      and (out / "summary.json").is_file()):
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    summary = json.loads((out / "summary.json").read_text())
    summary["process_s"] = elapsed
    return summary


def alternate(case: str, key: str, choices: tuple[str, ...], out: Path, repeats: int,
              sets: tuple[str, ...] = (), ranks: int = 1) -> dict[str, list[dict]]:
    """Run ``case`` with ``--set key=choice`` for each choice in turn, ``repeats`` times.

    Alternating the choices lets the machine's drift fall on all of them alike. Returns
    each choice's summaries in run order; runs go to ``out/<choice>_<k>``.
    """
    runs: dict[str, list[dict]] = {c: [] for c in choices}
    for k in range(repeats):
        for choice in choices:
            s = run_case_process(case, out / f"{choice}_{k}", ranks,
                                 sets=(*sets, f"{key}={choice}"))
            runs[choice].append(s)
            print(case, " ".join(sets), choice, f"{s['timing']['wall_s']:.1f} s", flush=True)
    return runs


def study_runs(case: str, vary: dict[str, tuple], out: Path, sets: tuple[str, ...] = (),
               ranks: int = 1, jobs: int = 1, metrics: tuple[str, ...] = (),
               drape: bool = False) -> list[tuple[object, dict]]:
    """Run ``case`` over every combination of ``vary`` as a ``forming study`` in ``out``.

    With ``drape``, each run is ``forming drape`` (``forming study --drape``). Runs
    already in ``out`` with the same settings are reused (a benchmark can be resumed);
    ``study.csv``, ``study.md`` and the study's PNGs (of ``metrics``, or of every metric)
    are written there.

    Returns:
        (study row, the run's ``summary.json`` or {} if it wrote none) per combination, in
        the order of the levels.
    """
    sys.path.insert(0, str(REPO))
    from forming.study import parse_study, run_study
    from forming.study_report import report

    levels = [f"{k}={':'.join(str(v) for v in vals)}" for k, vals in vary.items()]
    study = parse_study(case, levels, out, sets, metrics, "finest", jobs, ranks, drape)
    rows = run_study(study)
    report(study, rows)
    pairs = []
    for row in rows:
        try:
            summary = json.loads((row.folder / "summary.json").read_text())
        except (OSError, json.JSONDecodeError):
            summary = {}
        pairs.append((row, summary))
    return pairs


def machine() -> str:
    """One line describing the machine the figures were measured on."""
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def update_section(name: str, body: str, path: Path = PERFORMANCE_MD) -> None:
    """Replace the text between ``<!-- BEGIN name -->`` and ``<!-- END name -->``."""
    text = path.read_text() if path.exists() else "# Performance\n"
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    if begin in text:
        text = re.sub(re.escape(begin) + r".*?" + re.escape(end), lambda _m: block, text,
                      flags=re.S)
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    path.write_text(text)
