"""Meso against macro hemisphere forming (issue 20): docs/validation.md ``meso_hemisphere``.

``meso_hemisphere`` (cell walls, explicit) without and with the blank holder, and the
macro ``hemisphere`` (homogenised core, implicit, quarter model) on the same scaled
geometry: a 36 mm square blank (the meso patch is 37.5 x 34.6 mm), 3 mm thick, punch
15 mm, die opening 21.6 mm, edge radii 1.5 mm, 3.75 mm of stroke (the paper's scene
times 0.15, half its stroke). The figures set side by side are the ones both models
give: the punch force, the core's compaction under the punch (meso: one minus the wall
height over the initial one, mean over the wall columns under the punch's cap; macro:
the mean crushing strain under the punch), and the flange's lift off the die (meso:
the highest bottom node beyond the die's edge; macro: the largest vertical motion of the
blank's free edges).

Runs: ``results/meso_hemisphere_free``, ``results/meso_hemisphere_holder`` (each on one
rank, the two at once), ``results/macro_hemisphere_scaled_free`` and ``_holder``; a
folder that holds a finished run (completed or failed) is reused, so the section can be
written again from the runs (``--report`` runs none).

Run: ``python benchmarks/validate_meso_hemisphere.py`` (about an hour on 2 cores, nearly
all in the meso run without the holder).
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from _report import REPO, machine, run_case_process, update_section
from validate_meso_explicit import commit

VALIDATION_MD = REPO / "docs" / "validation.md"
GEOMETRY = ("size=36", "thickness=3", "punch_diameter=15", "die_diameter=21.6",
            "edge_radius=1.5", "stroke=3.75")
RUNS = {  # folder: (case, settings)
    "meso_hemisphere_free": ("meso_hemisphere", ()),
    "meso_hemisphere_holder": ("meso_hemisphere", ("blank_holder=true",)),
    "macro_hemisphere_scaled_free": ("hemisphere", GEOMETRY),
    "macro_hemisphere_scaled_holder": ("hemisphere", (*GEOMETRY, "blank_holder=true")),
}


def finished(folder: Path) -> dict | None:
    """The summary of a finished run in ``folder`` (completed, failed or interrupted)."""
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    return summary if summary.get("status") in ("completed", "failed", "interrupted") else None


def runs(report: bool) -> dict[str, dict]:
    """Every run's summary: reused, or run (two at a time) unless ``report``."""
    out = {name: finished(REPO / "results" / name) for name in RUNS}
    missing = [name for name, s in out.items() if s is None]
    if missing and not report:
        def one(name: str) -> dict:
            case, sets = RUNS[name]
            return run_case_process(case, REPO / "results" / name, sets=sets,
                                    allow_failure=True)

        with ThreadPoolExecutor(2) as pool:
            for name, summary in zip(missing, pool.map(one, missing), strict=True):
                out[name] = summary
    return out


def at_stroke(name: str, stroke: float, column: str) -> float:
    """A history column of run ``name`` at ``stroke`` [mm] (linear between rows)."""
    h = np.atleast_1d(np.genfromtxt(REPO / "results" / name / "history.csv", delimiter=",",
                                    names=True))
    if column not in h.dtype.names:
        return float("nan")
    return float(np.interp(stroke, h["stroke_mm"], h[column]))


def row(label: str, s: dict | None, keys: tuple[str, str, str]) -> str:
    """A table row: status, stroke, force, compaction under the punch, flange lift, time."""
    if not s:
        return f"| {label} | not run | | | | | | |"
    m = s.get("metrics", {})
    force, compaction, lift = (m.get(k, float("nan")) for k in keys)
    stroke = m.get("stroke_reached_mm", s.get("load_parameter_reached", 0.0) * 3.75)
    status = s["status"] if s["status"] == "completed" else f"{s['status']}: {s.get('reason')}"
    if s.get("restarted_from"):
        status += f" (restarted at load {s['restarted_from']['t']:.2f}; wall: that part)"
    return (f"| {label} | {status} | {stroke:.2f} | {force:.3g} | {compaction:.3g} | "
            f"{lift:.3g} | {s['timing']['wall_s']:.0f} | {commit(s)} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", action="store_true", help="write from the runs there")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO))
    s = runs(args.report)
    meso = ("punch_force_max_N", "compaction_mean_under_punch", "flange_lift_max_mm")
    macro = ("punch_force_max_N", "crushing_strain_mean_under_punch", "edge_lift_max_mm")
    lines = [
        "Written by `python benchmarks/validate_meso_hemisphere.py` (" + machine() + "). "
        "The paper's hemisphere scene times 0.15 and half its stroke: 36 mm blank, 3 mm "
        "core, punch 15 mm, die opening 21.6 mm, 3.75 mm of stroke; the meso patch keeps "
        "the real cells (5 x 4 cells, 37.5 x 34.6 mm), so the punch spans about two cells "
        "(`cases/meso_hemisphere.py`). Compaction: meso, one minus the wall height over "
        "the initial one, mean over the wall columns under the punch's cap; macro, the "
        "mean crushing strain under the punch. Lift: meso, the highest wall bottom beyond "
        "the die's edge; macro, the largest vertical motion of the blank's free edges. "
        "Forces are the whole part's.",
        "",
        "| run | status | stroke [mm] | punch force max [N] | compaction under punch | "
        "flange lift [mm] | wall [s] | commit |",
        "|---|---|---|---|---|---|---|---|",
        row("meso, no holder", s["meso_hemisphere_free"], meso),
        row("meso, holder", s["meso_hemisphere_holder"], meso),
        row("macro, no holder", s["macro_hemisphere_scaled_free"], macro),
        row("macro, holder", s["macro_hemisphere_scaled_holder"], macro),
    ]
    reached = [(s[n] or {}).get("metrics", {}).get("stroke_reached_mm", 0.0)
               for n in ("meso_hemisphere_free", "meso_hemisphere_holder")]
    common = min(reached)
    if 0 < common < max(reached) - 1e-9:
        lines += ["", f"At {common:.2f} mm of stroke, which both meso runs reached (from "
                  "their histories; the macro force from its history):", "",
                  "| run | punch force [N] | compaction under punch | flange lift [mm] |",
                  "|---|---|---|---|"]
        for name, label in (("meso_hemisphere_free", "meso, no holder"),
                            ("meso_hemisphere_holder", "meso, holder")):
            lines.append(f"| {label} | {at_stroke(name, common, 'force_punch_z_N'):.3g} | "
                         f"{at_stroke(name, common, 'compaction_mean_under_punch'):.3g} | "
                         f"{at_stroke(name, common, 'flange_lift_max_mm'):.3g} |")
        for name, label in (("macro_hemisphere_scaled_free", "macro, no holder"),
                            ("macro_hemisphere_scaled_holder", "macro, holder")):
            lines.append(f"| {label} | {at_stroke(name, common, 'force_punch_z_N'):.3g} | "
                         "| |")
    for name in ("meso_hemisphere_free", "meso_hemisphere_holder"):
        m = (s[name] or {}).get("metrics", {})
        if m:
            lines.append("")
            lines.append(
                f"`{name}`: damaged wall volume {100 * m['damaged_volume_fraction']:.2g}% "
                f"of the walls, {100 * m['damaged_under_punch_fraction']:.0f}% of it under "
                f"the punch; compaction on the flange {m['compaction_mean_flange']:.3g}, "
                f"largest {m['compaction_max']:.3g}; kinetic over internal energy up to "
                f"{m['kinetic_to_internal_max']:.2f}, mass added "
                f"{100 * m['mass_added_fraction']:.0f}%.")
    update_section("meso_hemisphere", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))
    cost = ["## `meso_hemisphere`: cost", "",
            "Written by `python benchmarks/validate_meso_hemisphere.py` (docs/validation.md, "
            f"`meso_hemisphere`, has the results); {machine()}. Each meso run on one rank; "
            "the two run at once (each has a core), then the macro runs (the wall times "
            "are of a machine with both cores busy).", "",
            "| run | status | load reached | elements | work | "
            "us per element-increment | wall [s] |", "|---|---|---|---|---|---|---|"]
    for name in RUNS:
        r = s[name]
        if not r:
            continue
        t = r["timing"]
        per = t.get("us_per_element_increment")
        status = r["status"]
        if r.get("restarted_from"):  # the wall time is the restarted part's
            back = r["restarted_from"]
            status += (f", restarted at load {back['t']:.2f} (first part on "
                       f"{back['ranks']} rank(s)); wall of the restarted part, on "
                       f"{r['ranks']} ranks")
        cost.append(f"| {name} | {status} | {r['load_parameter_reached']:.3f} | "
                    f"{r['mesh']['cells']} | {t['work']} ({t['work_name']}) | "
                    f"{'' if per is None else f'{per:.1f}'} | {t['wall_s']:.0f} |")
    update_section("meso_hemisphere_cost", "\n".join(cost))


if __name__ == "__main__":
    main()
