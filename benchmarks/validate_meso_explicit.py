"""Explicit meso runs with walls that touch (issue 20): docs/validation.md ``meso_explicit``.

1. ``meso_compression`` on the 1 x 1 patch, bonded platens, fracturing walls, explicit,
   to ``--strain`` (0.75 by default): the walls fold, fracture and meet, and the
   self-contact (docs/theory.md §15) keeps them from passing through each other; the
   nominal curve with the three regions of the paper's Fig. 6.
2. The paper's three variants with a touching top platen (friction 0.36): original
   (the platen on the wall edges), dummy flanges, dummy infill, explicit, to 0.1: which
   run through, next to the paper's Table 2.
3. ``meso_crushing`` with its defaults: the square punch on a 2 x 2 patch.

Every run is a ``forming study`` run in ``results/validate_meso_explicit`` (a rerun
reuses completed and failed runs; delete the folder to measure again). Serial runs.

Run: ``python benchmarks/validate_meso_explicit.py`` (about 70 minutes on one core);
``--report`` writes the sections from the runs already in the folder (stopped or
interrupted ones included, each with the commit it ran at) without running any.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np
from _report import REPO, machine, study_runs, update_section
from validate_meso import footprint

sys.path.insert(0, str(REPO))

VALIDATION_MD = REPO / "docs" / "validation.md"
PERFORMANCE_MD = REPO / "docs" / "performance.md"
FIGURES = REPO / "docs" / "figures"
PAPER_PEAK = (0.03, 0.40)  # measured C365 peak (strain, MPa), docs/materials.md
PAPER_PLATEAU = 0.25  # measured plateau [MPa] (estimate of Fig. 6)
PAPER_TABLE2 = {"original": "323.7 s, did not converge", "flange": "164.9 s",
                "infill": "321.6 s"}
RATE = 62.5  # nominal strain rate of every run [1/s] (0.25 in 0.004 s, as meso_fracture)
EXPLICIT = ("solver=explicit", "stabilisation=0", "explicit.target_time_step=2e-7")


def explicit_sets(strain: float, *more: str) -> tuple[str, ...]:
    """The ``--set`` items of an explicit meso run to ``strain`` at :data:`RATE`."""
    return (f"strain={strain:g}", *EXPLICIT, f"explicit.loading_time={strain / RATE:g}",
            *more)


def existing(vary: dict[str, tuple], out: Path) -> list[tuple[object, dict]]:
    """The runs of a study already in ``out`` (any status), without running any."""
    from forming.study import Row, folder_name

    pairs = []
    for level in vary[next(iter(vary))]:
        values = {next(iter(vary)): str(level)}
        folder = out / "runs" / folder_name(values)
        try:
            summary = json.loads((folder / "summary.json").read_text())
        except (OSError, json.JSONDecodeError):
            pairs.append((Row(values, folder, "not run"), {}))
            continue
        pairs.append((Row.from_summary(values, folder, summary), summary))
    return pairs


def runs_or_report(report: bool, case: str, vary: dict[str, tuple], out: Path,
                   sets: tuple[str, ...] = (), jobs: int = 1) -> list[tuple[object, dict]]:
    """The study's runs in ``out``: run (reusing what is there) or, with ``report``, only
    read (:func:`existing`: a plain study would run an interrupted run again)."""
    if report:
        return existing(vary, out)
    return study_runs(case, vary, out, sets=sets, jobs=jobs)


def status_text(row, summary: dict) -> str:
    """A run's status, with the reason unless it completed."""
    status = summary.get("status", row.status)
    return status if status == "completed" else f"{status}: {summary.get('reason', row.reason)}"


def commit(summary: dict) -> str:
    """The short commit a run ran at (``?`` if unknown, ``+`` if the checkout was dirty)."""
    git = (summary.get("run") or {}).get("git") or {}
    return (git.get("commit") or "?")[:7] + ("+" if git.get("dirty") else "")


def curve(row, summary: dict) -> tuple[np.ndarray, np.ndarray]:
    """Nominal strain and stress of a run (the platen's force over the footprint)."""
    h = np.atleast_1d(np.genfromtxt(row.folder / "history.csv", delimiter=",", names=True))
    e = h["t"] * summary["parameters"]["strain"]
    cols = [c for c in h.dtype.names if c.startswith(("reaction_", "force_platen"))
            and c.endswith("_z_N")]
    force = sum(h[c] for c in cols)
    sign = -1.0 if cols[0].startswith("reaction_") else 1.0
    return e, sign * force / footprint(summary)


def regions(e: np.ndarray, s: np.ndarray, peak_strain: float) -> tuple[float, float]:
    """Plateau (mean stress from twice the peak strain to 0.5) and densification onset.

    The onset is the first strain past the curve's lowest point after the peak at which
    the stress exceeds twice the plateau; nan when the curve does not get there.
    """
    band = (e >= 2 * peak_strain) & (e <= 0.5)
    plateau = float(s[band].mean()) if band.any() else float("nan")
    after = e > peak_strain
    lowest = e[after][int(np.argmin(s[after]))] if after.any() else np.inf
    above = np.nonzero((e > lowest) & (s > 2 * plateau))[0]
    return plateau, float(e[above[0]]) if above.size else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--strain", type=float, default=0.75, help="bonded run's strain")
    parser.add_argument("--variant-strain", type=float, default=0.1,
                        help="touching-platen runs' strain")
    parser.add_argument("--report", action="store_true",
                        help="write the sections from the runs in the folder, run none")
    args = parser.parse_args()
    out = REPO / "results" / "validate_meso_explicit"

    def runs(case: str, vary: dict[str, tuple], sub: str, sets: tuple[str, ...] = ()):
        return runs_or_report(args.report, case, vary, out / sub, sets)

    (bonded_row, bonded), = runs("meso_compression", {"cells": ("1,1",)}, "bonded",
                                 explicit_sets(args.strain))
    touching = runs("meso_compression", {"variant": ("original", "flange", "infill")},
                    "contact", explicit_sets(args.variant_strain, "cells=1,1", "platen=contact",
                                     "platen_stick=augmented"))
    lines = ["## Meso-scale honeycomb: explicit runs, walls that touch (issue 20)", "",
             "Fracturing walls (docs/theory.md §15), the 1 x 1 patch, serial, explicit "
             "with mass scaling (`" + " ".join(f"--set {x}" for x in EXPLICIT)
             + f"`; nominal strain rate {RATE:g}/s, as in 'fracturing cell walls'), walls "
             "in contact with each other (`self_contact`, the default). "
             f"`python benchmarks/validate_meso_explicit.py`; {machine()}.", "",
             "### Bonded platens, to densification", "",
             "| status | peak [MPa] | at strain | plateau [MPa] (2 x peak strain to 0.5) "
             "| densification onset (stress 2 x plateau) | stress at 0.6 / 0.7 [MPa] "
             "| strain reached | deepest wall overlap [mm] | kinetic / internal at most "
             "| increments | wall [s] | commit |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    m = bonded.get("metrics", {})
    curves = []
    if m:
        e, s = curve(bonded_row, bonded)
        plateau, onset = regions(e, s, m["peak_strain"])
        at = [float(np.interp(x, e, s)) if e[-1] >= x else float("nan") for x in (0.6, 0.7)]
        status = status_text(bonded_row, bonded)
        lines.append(
            f"| {status} | {m['peak_stress_MPa']:.3f} | {m['peak_strain']:.4f} "
            f"| {plateau:.3f} | {onset:.3f} | {at[0]:.3f} / {at[1]:.3f} "
            f"| {m['final_strain']:.4f} | {m.get('self_contact_penetration_max_mm', 0):.4f} "
            f"| {100 * m['kinetic_to_internal_max']:.1f}% "
            f"| {bonded['timing']['time_steps']} | {bonded['timing']['wall_s']:.0f} "
            f"| {commit(bonded)} |")
        curves.append((e, s, "bonded platens (meso, explicit)", "-"))
        ledger = np.atleast_1d(np.genfromtxt(bonded_row.folder / "history.csv",
                                             delimiter=",", names=True))["energy_friction_Nmm"]
        lines += ["", f"- The plateau, {plateau:.3f} MPa, against the measured core's about "
                  f"{PAPER_PLATEAU} MPa (docs/materials.md, an estimate from Fig. 6).",
                  f"- Strain reached {m['final_strain']:.3f}"
                  + ("." if bonded["status"] == "completed" else
                     f" ({bonded['status']}); densification "
                     + ("not reached." if np.isnan(onset) else f"from {onset:.3f}."))
                  + " The 10 mm core's 1 x 1 patch runs on to 0.8 and densifies: 'Meso "
                  "patch size', below.",
                  f"- The contact's ledger (penalty work, with the interface terms') "
                  f"ended at {ledger[-1]:.2f} N mm (lowest {ledger.min():.2f}): negative "
                  "means the penalty gave the walls energy it had not stored."]
        for name, png in (("folded", "folded_walls.png"), ("damaged", "damaged_walls.png")):
            if (bonded_row.folder / png).is_file():
                shutil.copy(bonded_row.folder / png, FIGURES / f"meso_explicit_{name}.png")
    else:
        lines.append(f"| {bonded_row.status}: {bonded.get('reason', '')} |" + " |" * 10)
    lines += ["", "### The paper's variants with a touching top platen", "",
              f"Top platen a rigid tool with friction 0.36 (the augmented stick law: the "
              "elastic-slip law, the case's default for implicit runs, breaks the energy "
              "balance of explicit increments: docs/validation.md, `strip_bending`), to "
              f"{args.variant_strain:g}. The "
              "tool touches every node of the walls' quadratic faces (Gauss-Lobatto nodal "
              "rule; with the vertex rule only their corners touched, 6 times too "
              "compliant: tests/test_explicit.py). The implicit touching-platen rows of "
              "'cell walls (issue 20, first part)' were measured with the vertex rule and "
              "have not been rerun since.", "",
              "| variant | status | strain reached | peak [MPa] | at strain "
              "| stress at the end [MPa] | deepest wall overlap [mm] "
              "| kinetic / internal at most | increments | wall [s] | paper, Table 2 "
              "| commit |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|"]
    for row, s_ in touching:
        v, mm = row.values["variant"], s_.get("metrics", {})
        status = status_text(row, s_)
        if not mm:
            lines.append(f"| {v} | {status} |" + " |" * 8 + f" {PAPER_TABLE2[v]} |")
            continue
        lines.append(
            f"| {v} | {status} | {mm['final_strain']:.4f} | {mm['peak_stress_MPa']:.3f} "
            f"| {mm['peak_strain']:.4f} | {mm['final_stress_MPa']:.3f} "
            f"| {mm.get('self_contact_penetration_max_mm', 0):.4f} "
            f"| {100 * mm['kinetic_to_internal_max']:.1f}% | {s_['timing']['time_steps']} "
            f"| {s_['timing']['wall_s']:.0f} | {PAPER_TABLE2[v]} | {commit(s_)} |")
        e, s = curve(row, s_)
        curves.append((e, s, f"touching platen, {v}", "--"))
    crushing = runs("meso_crushing", {"cells": ("2,2",)}, "crushing")
    lines += crushing_lines(crushing)
    import forming  # noqa: F401  (PETSc before dolfinx)
    from forming.materials.library import honeycomb_core
    from forming.output import plot_curves

    grid = np.linspace(0.0, args.strain, 200)
    curves += [(grid, honeycomb_core("isotropic").curve.interpolate(grid),
                "macro model's C365 curve (estimate of Fig. 6)", "k:"),
               (np.array([PAPER_PEAK[0]]), np.array([PAPER_PEAK[1]]),
                "measured peak (paper, Fig. 6)", "ks")]
    plot_curves(FIGURES / "meso_explicit_stress_strain.png", curves, "nominal strain",
                "nominal stress [MPa]", "Meso compression, explicit, walls in contact")
    lines += ["", "![meso explicit stress-strain](figures/meso_explicit_stress_strain.png)"]
    lines += [f"![{n} walls, bonded, explicit](figures/meso_explicit_{n}.png)"
              for n in ("folded", "damaged") if (FIGURES / f"meso_explicit_{n}.png").is_file()]
    update_section("meso_explicit", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))
    cost = cost_lines([("meso_compression, bonded", bonded_row, bonded)]
                      + [(f"meso_compression, touching, {r.values['variant']}", r, x)
                         for r, x in touching]
                      + [(f"meso_crushing, {r.values['cells']}", r, x) for r, x in crushing])
    update_section("meso_explicit_cost", "\n".join(cost), PERFORMANCE_MD)
    print("\n".join(cost))


def crushing_lines(runs: list) -> list[str]:
    """The square punch on a patch of walls (``meso_crushing``)."""
    lines = ["", "### `meso_crushing`: the square punch on a patch of walls", "",
             "The paper's Fig. 12 scene scaled to a meso run (the case's docstring): a 10 mm "
             "core (half the paper's), the punch over the middle half of the patch's width "
             "and depth with 2 mm fillets, pressed by half the core's thickness (as in the "
             "paper), friction 0.36; walls held at the bottom. Settlement: the mean downward "
             "move of the wall tops under the punch's flat face and outside the punch.", "",
             "| patch | status | stroke reached [mm] | punch force max [N] | settlement "
             "inside / outside (largest outside) [mm] | damaged volume outside the punch "
             "| deepest wall overlap [mm] | kinetic / internal at most | wall [s] | commit |",
             "|---|---|---:|---:|---|---:|---:|---:|---:|---|"]
    for row, s in runs:
        m = s.get("metrics", {})
        status = status_text(row, s)
        if not m:
            lines.append(f"| {row.values['cells']} | {status} |" + " |" * 7)
            continue
        lines.append(
            f"| {row.values['cells']} | {status} | {m['stroke_reached_mm']:.2f} "
            f"| {m['punch_force_max_N']:.1f} | {m['settlement_inside_mm']:.2f} / "
            f"{m['settlement_outside_mm']:.2f} ({m['settlement_outside_max_mm']:.2f}) "
            f"| {100 * m['damaged_volume_outside_fraction']:.1f}% "
            f"| {m.get('self_contact_penetration_max_mm', 0):.4f} "
            f"| {100 * m['kinetic_to_internal_max']:.1f}% | {s['timing']['wall_s']:.0f} "
            f"| {commit(s)} |")
        h = np.atleast_1d(np.genfromtxt(row.folder / "history.csv", delimiter=",",
                                        names=True))
        i = int(np.argmax(h["force_punch_z_N"]))
        travel = s["parameters"]["stroke"] * s["parameters"]["height"]
        lines += ["", f"At the force peak ({h['force_punch_z_N'][i]:.1f} N, "
                  f"{h['t'][i] * travel:.2f} mm of stroke) the wall tops under the punch "
                  f"had settled {h['settlement_inside_mm'][i]:.3f} mm and those outside "
                  f"{h['settlement_outside_mm'][i]:.3f} mm (largest "
                  f"{h['settlement_outside_max_mm'][i]:.3f} mm)."]
        png = row.folder / "folded_walls.png"
        if png.is_file():
            shutil.copy(png, FIGURES / "meso_crushing_walls.png")
            lines += ["", "![walls under the punch](figures/meso_crushing_walls.png)"]
    return lines


def cost_lines(runs: list) -> list[str]:
    """The explicit meso runs' cost (docs/performance.md)."""
    lines = ["## Explicit meso runs: cost", "",
             "Written by `python benchmarks/validate_meso_explicit.py` (docs/validation.md, "
             f"'explicit runs, walls that touch', has the results); serial, {machine()}. "
             "The paper's Abaqus/Explicit meso runs (Table 2): 164.9 s (dummy flanges), "
             "321.6 s (dummy infill), 323.7 s (original, did not converge), on a machine "
             "and patch it does not state.", "",
             "| run | status | load reached | unknowns | elements | increments "
             "| us per element and increment | wall [s] |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for name, row, s in runs:
        t = s.get("timing", {})
        if not t:
            lines.append(f"| {name} | {row.status} |" + " |" * 6)
            continue
        lines.append(f"| {name} | {s['status']} | {s.get('load_parameter_reached', 0):.3f} "
                     f"| {row.unknowns} | {t['elements']} | {t['time_steps']} "
                     f"| {t.get('us_per_element_increment', float('nan')):.1f} "
                     f"| {t['wall_s']:.0f} |")
    return lines


if __name__ == "__main__":
    main()
