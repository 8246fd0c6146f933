"""What accuracy costs in time: implicit load steps against explicit loading time (issue #5).

`hemisphere` with the blank holder (core only, 12 x 12 x 3 quarter mesh) run with

- the implicit solver at several largest load steps (``max_step``), and
- the explicit solver at several loading times and mass-scaling targets, with full
  integration (the default), with reduced integration (one point per element,
  hourglass control; issue 16), with thickness integration (one point in plane, two
  through the thickness) and with adaptive integration (thickness integration until an
  element crushes unevenly, full integration from then),

each point giving its error against a converged reference (the implicit solver at a
load step four times finer than the finest point) and its wall time. The error is the
RMS difference of the punch force-stroke curve relative to the reference's peak (the
explicit forces are interval means, compared with the reference averaged over the same
intervals, as in ``forming compare``); the crushed volume's relative error is listed next
to it. Writes
the chart ``docs/figures/accuracy_vs_time.png`` and the ``accuracy_vs_time`` section of
docs/performance.md, which states which solver reaches 1% and 5% error sooner.

Each series is a ``forming study`` in ``--work`` (``results/accuracy_vs_time``), one run at a
time on one rank; a rerun reuses the finished runs (delete the folder to time afresh).
Run alone (wall times): ``python benchmarks/accuracy_vs_time.py`` (21.6 minutes on one
core of an Intel Xeon, 2026-12-03; ``--quick`` for a 6 x 6 x 2 mesh and fewer points).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from _report import REPO, machine, study_runs, update_section

sys.path.insert(0, str(REPO))
from forming.compare import force_differences, interval_means  # noqa: E402
from forming.solver.options import ExplicitOptions  # noqa: E402

STROKE = 50.0


def _curve(out: Path) -> tuple[np.ndarray, np.ndarray]:
    """Load parameters and punch force [N] of a run's history."""
    h = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    return np.atleast_1d(h["t"]), np.atleast_1d(h["force_punch_z_N"])  # whole part


def _error(ref: tuple[np.ndarray, np.ndarray], run: tuple[np.ndarray, np.ndarray],
           loading_time: float | None) -> float:
    """Force-stroke RMS error against the reference, relative to its peak.

    An explicit run (``loading_time`` given) writes interval means; the reference is
    averaged over the same intervals first, as in ``forming compare``.
    """
    (s_ref, f_ref), (s, f) = ref, run
    if loading_time is None:
        return force_differences((s_ref * STROKE, f_ref), (s * STROKE, f))["force_rms_diff_rel"]
    s_mean, f_filtered = interval_means(s_ref, f_ref, s, ExplicitOptions(loading_time))
    return force_differences((s_ref * STROKE, f_ref), (s_mean * STROKE, f), f_filtered)[
        "force_rms_diff_rel"]


def _cheapest(rows: list[dict], solver: str, tol: float, crushed: bool) -> dict | None:
    ok = [r for r in rows if r["solver"] == solver and r["status"] == "completed"
          and r["error"] <= tol and (not crushed or abs(r["crushed_error"]) <= tol)]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


def _verdict(rows: list[dict], tol: float, crushed: bool = False) -> str:
    """Which solver reaches ``tol`` force error sooner (``crushed``: and crushed volume)."""
    imp = _cheapest(rows, "implicit", tol, crushed)
    exp = _cheapest(rows, "explicit", tol, crushed)
    def say(r):
        return f"{r['label']}, {r['wall_s']:.0f} s" if r else "no setting reached it"
    if imp and exp:
        win = "implicit" if imp["wall_s"] < exp["wall_s"] else "explicit"
        ratio = max(imp["wall_s"], exp["wall_s"]) / min(imp["wall_s"], exp["wall_s"])
        lose = "explicit" if win == "implicit" else "implicit"
        if ratio < 1.1:  # a chosen margin: each point is one timed run, not a mean
            verdict = (f"a **tie** ({ratio:.2f}x, inside the 10% margin this study "
                       f"sets for one timed run per point)")
        else:
            verdict = (f"**{win}** is cheaper, by {ratio:.1f}x: the {lose} solver would need "
                       f"its cheapest run that reaches it {ratio:.1f} times faster to win")
    elif imp or exp:
        verdict = f"**{'implicit' if imp else 'explicit'}** is the only one to reach it"
    else:
        verdict = "neither reaches it"
    what = " in force and crushed volume" if crushed else ""
    return (f"- At {tol:.0%} error{what}: {verdict} (cheapest implicit: {say(imp)}; "
            f"cheapest explicit: {say(exp)}).")


def _chart(rows: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.8), dpi=120)
    for solver, style in (("implicit", "o-"), ("explicit", "s--"), ("explicit, mass scaled", "^:"),
                          ("explicit, reduced", "d-."), ("explicit, reduced, mass scaled", "v:"),
                          ("explicit, thickness", "p-."),
                          ("explicit, thickness, mass scaled", "h:"),
                          ("explicit, adaptive", "*-."),
                          ("explicit, adaptive, mass scaled", "x:")):
        pts = sorted((r for r in rows if r["series"] == solver and r["status"] == "completed"),
                     key=lambda r: r["wall_s"])
        if pts:
            ax.loglog([r["wall_s"] for r in pts], [max(r["error"], 1e-5) for r in pts], style,
                      label=solver)
            # the hourglass-controlled series lie in one cluster: the table names their
            # points, the legend their series
            if any(k in solver for k in ("reduced", "thickness", "adaptive")):
                continue
            for i, r in enumerate(pts):  # alternate above and below: close points
                ax.annotate(r["short"], (r["wall_s"], max(r["error"], 1e-5)), fontsize=7,
                            textcoords="offset points", xytext=(4, 4 if i % 2 else -10))
    for tol in (0.01, 0.05):
        ax.axhline(tol, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("wall time [s] (1 core)")
    ax.set_ylabel("punch force error (RMS / peak) vs reference")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3)
    fig.tight_layout()
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="coarse mesh, fewer points")
    parser.add_argument("--json", type=Path, default=None, help="also write the raw rows")
    parser.add_argument("--work", type=Path, default=REPO / "results" / "accuracy_vs_time",
                        help="the studies' folder (runs already there are reused)")
    parser.add_argument("--replot", type=Path, default=None,
                        help="rewrite the chart and the section from a --json file")
    args = parser.parse_args()
    if args.replot:
        data = json.loads(args.replot.read_text())
        for r in data["rows"]:
            if r["solver"] == "implicit":
                r["short"] = f"max {r['label'].split()[-1]} ({r['work']} steps)"
        write(data["rows"], data["reference"], data["cells"], data["quick"], data["machine"])
        return
    cells = "6,6,2" if args.quick else "12,12,3"
    base = (f"cells={cells}", "blank_holder=true")
    implicit_steps = (0.05, 0.02, 0.01) if args.quick else (0.05, 0.025, 0.01, 0.005)
    reference_step = implicit_steps[-1] / 4
    loading = (0.005, 0.01, 0.02) if args.quick else (0.005, 0.01, 0.02, 0.05)
    scaled_time, factors = 0.05, ((2.0,) if args.quick else (2.0, 4.0))  # dt factors
    work = args.work / ("quick" if args.quick else "full")
    rows: list[dict] = []
    (ref_row_, ref), = study_runs("hemisphere", {"max_step": (reference_step,)},
                                  work / "reference", (*base, f"min_step={reference_step / 100}"))
    if ref_row_.status != "completed":
        sys.exit(f"the reference run did not complete: {ref_row_.reason}")
    ref_curve = _curve(ref_row_.folder)
    ref_crushed = ref["metrics"]["crushed_volume_mm3"]

    def series(name: str, key: str, values: tuple, sets: tuple[str, ...], label, short,
               loading_time) -> list[dict]:
        """One study: ``key`` over ``values``; a row per run (the chart's points)."""
        out = []
        for (row, s), v in zip(study_runs("hemisphere", {key: values}, work / name.replace(
                ", ", "_").replace(" ", "_"), (*base, *sets)), values, strict=True):
            explicit = "solver=explicit" in sets
            timing, m = s.get("timing") or {}, s.get("metrics") or {}
            r = {"series": name, "solver": "explicit" if explicit else "implicit",
                 "label": label(v), "short": short(v), "status": row.status,
                 "wall_s": row.wall_s, "error": float("nan"), "crushed_error": float("nan"),
                 "work": timing.get("time_steps") if explicit else row.steps,
                 "ke_ie": m.get("kinetic_to_internal_max", float("nan")),
                 "mass_added": m.get("mass_added_fraction", 0.0),
                 "dt": timing.get("stable_time_step_s", float("nan"))}
            if row.status == "completed":
                r["error"] = _error(ref_curve, _curve(row.folder),
                                    loading_time(v) if explicit else None)
                r["crushed_error"] = m["crushed_volume_mm3"] / ref_crushed - 1
            if not explicit:
                r["short"] = f"{r['short']} ({r['work']} steps)"
            print(json.dumps(r), flush=True)
            out.append(r)
        return out

    rows += series("implicit", "max_step", implicit_steps, (), lambda v: f"max_step {v}",
                   lambda v: f"max {v:g}", None)
    explicit = series("explicit", "explicit.loading_time", loading, ("solver=explicit",),
                      lambda v: f"loading time {v} s", lambda v: f"{v * 1e3:g} ms",
                      lambda v: v)
    rows += explicit
    natural_dt = explicit[0]["dt"]
    targets = tuple(f * natural_dt for f in factors)
    scaled = ("solver=explicit", f"explicit.loading_time={scaled_time}")
    rows += series("explicit, mass scaled", "explicit.target_time_step", targets, scaled,
                   lambda v: f"loading time {scaled_time} s, target dt {v:.3g} s "
                             f"({v / natural_dt:g}x)",
                   lambda v: f"{scaled_time * 1e3:g} ms, dt x{v / natural_dt:g}",
                   lambda v: scaled_time)
    # one point (reduced), one point in plane (thickness), with hourglass control, or
    # thickness integration until an element crushes unevenly, full from then (adaptive)
    for kind in ("reduced", "thickness", "adaptive"):
        sets = ("solver=explicit", f"explicit.integration={kind}")
        rows += series(f"explicit, {kind}", "explicit.loading_time", loading[-2:], sets,
                       lambda v, k=kind: f"{k}, loading time {v} s",
                       lambda v, k=kind: f"{v * 1e3:g} ms, {k}", lambda v: v)
        rows += series(f"explicit, {kind}, mass scaled", "explicit.target_time_step", targets,
                       (*scaled, f"explicit.integration={kind}"),
                       lambda v, k=kind: f"{k}, loading time {scaled_time} s, target dt "
                                         f"{v:.3g} s ({v / natural_dt:g}x)",
                       lambda v, k=kind: f"{scaled_time * 1e3:g} ms, {k}, "
                                         f"dt x{v / natural_dt:g}",
                       lambda v: scaled_time)
    ref_row = {"wall_s": ref_row_.wall_s, "steps": ref_row_.steps,
               "force_max_N": float(np.max(ref_curve[1])), "crushed": ref_crushed,
               "max_step": reference_step}
    if args.json:
        args.json.write_text(json.dumps({"reference": ref_row, "rows": rows, "cells": cells,
                                         "quick": args.quick, "machine": machine()},
                                        indent=2))
    write(rows, ref_row, cells, args.quick, machine())


def _hourglassed(rows: list[dict], kind: str) -> str:
    """What the integration with hourglass control gets: force and crushing errors."""
    done = [r for r in rows if r["series"].startswith(f"explicit, {kind}")
            and r["status"] == "completed"]
    if not done:
        return ""
    force = [r["error"] for r in done]
    crushed = [r["crushed_error"] for r in done]
    where = ("'Adaptive integration in the explicit solver'" if kind == "adaptive"
             else "'Reduced and thickness integration'")
    return (f"{kind.capitalize()} integration: force error {min(force):.1%} to "
            f"{max(force):.1%}, crushed volume {min(crushed):+.0%} to {max(crushed):+.0%} "
            f"(docs/validation.md, {where}, has why).")


def write(rows: list[dict], ref_row: dict, cells: str, quick: bool, where: str) -> None:
    """The chart and the ``accuracy_vs_time`` section of docs/performance.md."""
    fig = REPO / "docs" / "figures" / "accuracy_vs_time.png"
    _chart(rows, fig, f"hemisphere with blank holder, {cells} mesh: error vs wall time")
    lines = [
        f"## Accuracy against time: implicit and explicit (`hemisphere`, blank holder, "
        f"{cells} quarter mesh)",
        "",
        f"`python benchmarks/accuracy_vs_time.py{' --quick' if quick else ''}`, one "
        f"process per point, run alone on {where}. Reference: the implicit solver with "
        f"max_step {ref_row['max_step']:g} ({ref_row['steps']} steps, {ref_row['wall_s']:.0f} s; "
        f"punch force max {ref_row['force_max_N']:.1f} N, crushed volume "
        f"{ref_row['crushed']:.0f} mm^3). Error: RMS difference of the punch force-stroke "
        "curve over the reference's peak force.",
        "",
        "| solver | setting | status | steps / increments | stable dt [s] | mass added | "
        "KE/IE max | force error | crushed volume error | wall [s] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        dt = f"{r['dt']:.3g}" if r["solver"] == "explicit" else ""
        kei = f"{r['ke_ie']:.1%}" if r["solver"] == "explicit" else ""
        added = f"{r['mass_added']:.1%}" if r["solver"] == "explicit" else ""
        lines.append(f"| {r['solver']} | {r['label']} | {r['status']} | {r['work']} | {dt} "
                     f"| {added} | {kei} | {r['error']:.2%} | {r['crushed_error']:+.2%} "
                     f"| {r['wall_s']:.1f} |")
    lines += ["", _verdict(rows, 0.01), _verdict(rows, 0.05), _verdict(rows, 0.05, crushed=True),
              "", " ".join(_hourglassed(rows, k) for k in ("reduced", "thickness", "adaptive")),
              "",
              "The crushed volume is a threshold measure (plastic volumetric strain above 0.01) "
              "that moves in whole cells: the implicit runs are "
              + ", ".join(f"{r['crushed_error']:+.1%} ({r['label']})" for r in rows
                          if r["solver"] == "implicit")
              + " from the reference.", "",
              "![error against wall time](figures/accuracy_vs_time.png)"]
    update_section("accuracy_vs_time", "\n".join(lines), REPO / "docs" / "performance.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
