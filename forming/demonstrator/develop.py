"""``forming optimise-blank CASE``: form, map the trim line back, re-mesh, form again.

Each run is the case itself (:func:`forming.case.run_case`, in this process and on its
ranks) with ``--set blank=<outline CSV>``; the geometry between runs is done on rank 0
(:mod:`forming.demonstrator.optimise`). A folder holding finished runs is resumed: a run
whose ``summary.json`` says completed with the same settings is not run again.

Outputs in the folder: ``run_K/`` (every run's usual outputs), ``blank_K.csv`` (the
outline run K formed), ``outlines.png`` (all outlines over the trim line),
``optimise.json`` (per run: the edge's largest and RMS distance to the trim line, wall
time) and the final outline as ``blank_final.csv`` and ``blank_final.dxf`` (a closed
LWPOLYLINE in mm, written with ezdxf, for a cutting table; a blank of the case
too: ``--set blank=blank_final.dxf``).
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from forming.case import run_case
from forming.demonstrator.dxf import write_outline
from forming.demonstrator.optimise import FormingMap, next_blank
from forming.errors import InputError

log = logging.getLogger(__name__)


def _write_csv(path: Path, outline: np.ndarray) -> Path:
    np.savetxt(path, outline, delimiter=",", header="x_mm,y_mm", comments="", fmt="%.6f")
    return path


def _reuse(run: Path, assignments: list[str]) -> dict | None:
    path = run / "summary.json"
    if not path.is_file():
        return None
    summary = json.loads(path.read_text())
    if summary.get("status") == "completed" and summary.get("assignments") == assignments:
        return summary
    return None


def _overlay(path: Path, outlines: list[np.ndarray], trim: np.ndarray, devs: list[float]) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 6.2))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    t = np.vstack([trim, trim[:1]])
    ax.plot(t[:, 0], t[:, 1], "k--", lw=1.2, label="trim line (finished part)")
    for k, (o, d) in enumerate(zip(outlines, devs, strict=False), start=1):
        c = np.vstack([o, o[:1]])
        ax.plot(c[:, 0], c[:, 1], lw=1.0, label=f"blank {k}: formed edge within {d:.2f} mm")
    if len(outlines) > len(devs):
        c = np.vstack([outlines[-1], outlines[-1][:1]])
        ax.plot(c[:, 0], c[:, 1], lw=1.0, label=f"blank {len(outlines)} (not run)")
    ax.set(aspect="equal", xlabel="x [mm]", ylabel="y [mm]",
           title="Blank outlines, run by run (flat), and the trim line")
    ax.legend(fontsize="small", loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path


def optimise_blank(case: str, out: Path, assignments: list[str], tolerance: float = 2.0,
                   max_runs: int = 4, margin: float = 0.0) -> dict:
    """Develop the net-shape blank of ``case`` (see the module docstring).

    Returns:
        The ``optimise.json`` record (on every rank).
    """
    if not tolerance > 0:
        raise InputError("--tolerance", f"must be > 0, got {tolerance}")
    if max_runs < 1:
        raise InputError("--max-runs", f"must be >= 1, got {max_runs}")
    if any(a.split("=", 1)[0].strip() == "blank" for a in assignments):
        raise InputError("--set blank", "the optimiser sets the blank; start from the case's")
    comm = MPI.COMM_WORLD
    out = Path(out)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    runs, outlines, blank = [], [], None
    record = {"case": case, "tolerance_mm": tolerance, "margin_mm": margin,
              "max_runs": max_runs, "converged": False}
    for k in range(1, max_runs + 1):
        run = out / f"run_{k}"
        args = list(assignments) + ([f"blank={blank}"] if blank else [])
        started = time.perf_counter()
        summary = _reuse(run, args)
        reused = summary is not None
        if summary is None:
            summary = run_case(case, run, args)
        entry = {"run": run.name, "blank": blank, "status": summary["status"],
                 "reused": reused, "wall_s": summary["timing"]["wall_s"] if reused
                 else time.perf_counter() - started}
        runs.append(entry)
        if summary["status"] != "completed":
            entry["reason"] = summary.get("reason")
            log.warning("run %d did not complete (%s): the optimisation stops", k,
                        summary.get("reason"))
            break
        fmap = FormingMap.read(run)
        dev = fmap.deviation()
        entry |= {"trim_deviation_max_mm": float(dev.max()),
                  "trim_deviation_rms_mm": float(np.sqrt(np.mean(dev ** 2)))}
        if k == 1:
            outlines.append(fmap.blank)
        log.info("run %d: formed edge within %.3f mm of the trim line (RMS %.3f)", k,
                 dev.max(), entry["trim_deviation_rms_mm"])
        if dev.max() <= tolerance:
            record["converged"] = True
            break
        if k == max_runs:
            break
        nxt = next_blank(fmap, margin) if comm.rank == 0 else None
        nxt = comm.bcast(nxt, root=0)
        outlines.append(nxt)
        blank = str((out / f"blank_{k + 1}.csv").resolve())
        if comm.rank == 0:
            _write_csv(Path(blank), nxt)
        comm.barrier()
    devs = [r["trim_deviation_max_mm"] for r in runs if "trim_deviation_max_mm" in r]
    record |= {"iterations": len(runs), "runs": runs, "trim_deviation_max_mm": devs,
               "trim_deviation_rms_mm": [r["trim_deviation_rms_mm"] for r in runs
                                         if "trim_deviation_rms_mm" in r]}
    if comm.rank == 0 and outlines:
        _write_csv(out / "blank_1.csv", outlines[0])
        final = outlines[len(devs) - 1] if devs else outlines[0]
        record["outline_csv"] = str(_write_csv(out / "blank_final.csv", final))
        record["outline_dxf"] = str(write_outline(out / "blank_final.dxf", final))
        record["overlay_png"] = str(_overlay(out / "outlines.png", outlines,
                                             FormingMap.read(out / runs[0]["run"]).trim,
                                             devs))
        (out / "optimise.json").write_text(json.dumps(record, indent=2))
    return comm.bcast(record, root=0)
