"""Scaling of the implicit solver: the sandwich under the hemisphere with blank holder.

For each mesh, number of ranks and linear solver: wall time, time in Newton (the
speed-ups use it: the wall time includes mesh generation, which only the first run of a
mesh pays), Newton iterations per
accepted step, the cost of one Newton iteration split into material kernel, assembly,
linear solve and contact (``timing.per_iteration_ms`` of summary.json, rank means),
and the peak resident memory (largest rank). Then the exponent ``p`` of a fit
``t_iteration = a N^p`` over the meshes (N unknowns), per solver and rank count, and
what it gives at 10^6 unknowns. Writes docs/performance.md's ``scaling`` section.

The stroke is shortened (``--stroke``, default 10 mm of the 50) and the steps are
coarser (``--max-step``, default 0.05 of it) so that the finer meshes fit in a session:
the per-iteration figures hardly depend on either.

Run: ``python benchmarks/scaling_study.py`` (defaults below; each run is a separate
process, nothing else should run on the machine).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, machine, run_case_process, update_section

MESHES = ("6,6,2", "12,12,3", "18,18,4")
SPLIT = ("kernel", "assembly", "linear_solve", "contact")


def fit_exponent(dofs: list[float], times: list[float]) -> tuple[float, float] | None:
    """Least-squares ``(a, p)`` of ``t = a N^p`` in log-log (None below two points)."""
    if len(dofs) < 2:
        return None
    p, log_a = np.polyfit(np.log(dofs), np.log(times), 1)
    return float(np.exp(log_a)), float(p)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=list(MESHES))
    parser.add_argument("--ranks", nargs="+", type=int, default=[1, 2])
    parser.add_argument("--solvers", nargs="+", default=["mumps", "gamg"])
    parser.add_argument("--lu-precision", default="double",
                        choices=("auto", "double", "single"),
                        help="MUMPS's factorisation (newton.lu_precision; the tables of "
                        "docs/performance.md were measured in double)")
    parser.add_argument("--stroke", type=float, default=10.0)
    parser.add_argument("--max-step", type=float, default=0.05,
                        help="largest load step (fraction of the stroke)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows here")
    parser.add_argument("--section", default="scaling",
                        help="docs/performance.md section to write (default: scaling)")
    parser.add_argument("--rows", type=Path, default=None,
                        help="write the section from rows printed by an earlier run (one "
                             "JSON object per line) instead of running")
    args = parser.parse_args()
    rows = []
    if args.rows is not None:
        rows = [json.loads(line) for line in args.rows.read_text().splitlines()
                if line.startswith("{")]
    else:
        rows = run_all(args)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    write_section(args, rows)


def newton_seconds(row: dict) -> float:
    """Time inside Newton [s]: the per-iteration split times the iterations.

    Unlike the wall time it excludes the set-up (mesh generation, which the first run
    of a mesh pays and later ones read from the mesh cache) and the output.
    """
    return row["newton"] * sum(row["split_ms"].get(k, 0.0) for k in SPLIT) / 1e3


def run_all(args) -> list[dict]:
    """Run every combination; one row each (also printed as a JSON line)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # compile the forms and kernels once, so that no timed run pays for it
        run_case_process("hemisphere", Path(tmp) / "warm-up", 1, allow_failure=True,
                         sets=("skins=true", "skin_contact=small", "blank_holder=true",
                               "cells=2,2,1", "stroke=1", "max_step=0.5"))
        for cells in args.meshes:
            for solver in args.solvers:
                for ranks in args.ranks:
                    out = Path(tmp) / f"{cells}_{solver}_{ranks}"
                    s = run_case_process(
                        "hemisphere", out, ranks, allow_failure=True,
                        sets=("skins=true", "skin_contact=small", "blank_holder=true",
                              f"cells={cells}",
                              f"stroke={args.stroke}", f"max_step={args.max_step}",
                              f"newton.linear_solver={solver}",
                              f"newton.lu_precision={args.lu_precision}"))
                    t = s["timing"]
                    rows.append({
                        "cells": cells, "solver": solver, "ranks": ranks,
                        "status": s["status"], "dofs": s["mesh"]["dofs"],
                        "wall_s": t["wall_s"], "steps": t["steps"],
                        "newton": t["newton_iterations"],
                        "newton_per_step": t["newton_per_step"],
                        "split_ms": t.get("per_iteration_ms", {}),
                        "peak_rss_mb": t.get("peak_rss_mb", float("nan")),
                        "force_N": s["metrics"].get("punch_force_max_N", float("nan")),
                    })
                    print(json.dumps(rows[-1]), flush=True)
    return rows


def write_section(args, rows: list[dict]) -> None:
    """The table, the fitted exponents and the 2-rank speed-ups, into performance.md."""
    lines = [
        f"Measured with `python benchmarks/scaling_study.py "
        f"--meshes {' '.join(args.meshes)} --solvers {' '.join(args.solvers)} --stroke "
        f"{args.stroke:g} --max-step {args.max_step:g}"
        f"{'' if args.lu_precision == 'double' else ' --lu-precision ' + args.lu_precision}"
        f"` on {machine()}: `hemisphere --set "
        f"skins=true --set "
        f"blank_holder=true`, the first {args.stroke:g} mm of the stroke. Per-iteration "
        f"times are rank means [ms].", "",
        "| mesh | unknowns | solver | ranks | status | wall [s] | in Newton [s] | steps "
        "| Newton/step | kernel | assembly | linear solve | contact | per iteration "
        "| peak RSS [MB] | punch force [N] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        sp = r["split_ms"]
        total = sum(sp.get(k, 0.0) for k in SPLIT)
        lines.append(
            f"| {r['cells']} | {r['dofs']} | {r['solver']} | {r['ranks']} | {r['status']} "
            f"| {r['wall_s']:.1f} | {newton_seconds(r):.1f} | {r['steps']} "
            f"| {r['newton_per_step']:.2f} | "
            + " | ".join(f"{sp.get(k, float('nan')):.1f}" for k in SPLIT)
            + f" | {total:.1f} | {r['peak_rss_mb']:.0f} | {r['force_N']:.2f} |")
    lines.append("")
    for solver in args.solvers:
        for ranks in args.ranks:
            sel = [r for r in rows if r["solver"] == solver and r["ranks"] == ranks
                   and r["status"] == "completed"]
            fit = fit_exponent([r["dofs"] for r in sel],
                               [sum(r["split_ms"].get(k, 0.0) for k in SPLIT) for r in sel])
            if fit is None:
                continue
            a, p = fit
            lines.append(f"- {solver}, {ranks} rank(s): time per Newton iteration ~ "
                         f"N^{p:.2f} over {len(sel)} meshes; at 10^6 unknowns "
                         f"{a * 1e6 ** p / 1e3:.0f} s per iteration by this fit.")
    for cells in args.meshes:
        for solver in args.solvers:
            pair = {r["ranks"]: r for r in rows if r["cells"] == cells
                    and r["solver"] == solver and r["status"] == "completed"}
            if 1 in pair and 2 in pair:
                same = pair[1]["newton"] == pair[2]["newton"]
                lines.append(f"- {cells}, {solver}: 2-rank speed-up in Newton "
                             f"{newton_seconds(pair[1]) / newton_seconds(pair[2]):.2f}"
                             + ("" if same else " (the Newton iteration counts differ)")
                             + ".")
    lines += _against_mumps(args, rows)
    update_section(args.section, "\n".join(lines), REPO / "docs" / "performance.md")
    print("\n".join(lines))


def _against_mumps(args, rows: list[dict]) -> list[str]:
    """Each other solver's Newton time, linear solve and memory over MUMPS's, per run."""
    out = []
    for cells in args.meshes:
        for ranks in args.ranks:
            runs = {r["solver"]: r for r in rows if r["cells"] == cells
                    and r["ranks"] == ranks and r["status"] == "completed"}
            base = runs.get("mumps")
            for solver, r in runs.items():
                if base is None or solver == "mumps":
                    continue
                same = "" if r["newton"] == base["newton"] else \
                    f" ({r['newton']} Newton iterations against {base['newton']})"
                solve = r["split_ms"]["linear_solve"] / base["split_ms"]["linear_solve"]
                out.append(
                    f"- {cells}, {ranks} rank(s): {solver} takes "
                    f"{newton_seconds(r) / newton_seconds(base):.2f} of MUMPS's time in "
                    f"Newton, {solve:.2f} of its linear solve per iteration and "
                    f"{r['peak_rss_mb'] / base['peak_rss_mb']:.2f} of its peak memory{same}.")
    return out


if __name__ == "__main__":
    main()
