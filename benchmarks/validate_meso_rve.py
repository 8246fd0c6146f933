"""The meso patch's size (issue 20): is a 3 x 3 patch a representative volume?

``meso_compression`` with fracturing walls that touch each other, bonded platens,
explicit (the settings of docs/validation.md 'explicit runs, walls that touch': mass
scaling to a 2e-7 s step, nominal strain rate 62.5/s), to 0.25 nominal strain, on
patches of 1 x 1, 3 x 3 and 4 x 4 cells. A 10 mm core with 4 layers of elements keeps
the default element size (the 20 mm core has 8) at half the cost. The patches are
compared at one height; the 10 mm core's curve is not the 20 mm core's (its walls hold
to a higher peak at a larger strain: docs/validation.md). Each curve is compared with
the largest patch's: the RMS difference of the nominal stress over their common
strains, over the largest patch's peak (the issue's target: within 5%), and the peak
and plateau.

Then the 1 x 1 (serial) and 3 x 3 (2 ranks) patches of the same core on to 0.8 nominal
strain at the same strain rate: the three regions of the paper's Fig. 6, densification
included, with the walls' self-contact keeping the folds apart.

Writes docs/validation.md ``meso_rve``, docs/performance.md ``meso_rve_cost`` and
docs/figures/meso_rve_stress_strain.png and meso_densification.png. The
runs are in ``results/validate_meso_rve`` (a rerun reuses every run that ended; delete a
folder to measure it again).

Run: ``python benchmarks/validate_meso_rve.py`` (three hours or more on 2 cores: the
larger patches on 2 ranks); ``--report`` writes the section from the runs already
there without running any.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from _report import REPO, machine, read_summary, run_case_process, update_section
from validate_meso_explicit import commit, curve, regions, status_text

sys.path.insert(0, str(REPO))

VALIDATION_MD = REPO / "docs" / "validation.md"
PERFORMANCE_MD = REPO / "docs" / "performance.md"
FIGURES = REPO / "docs" / "figures"
OUT = REPO / "results" / "validate_meso_rve"
# (cells, ranks): the largest patch last (the reference)
PATCHES = (("1,1", 1), ("3,3", 2), ("4,4", 2))
SETS = ("height=10", "layers=4", "strain=0.25", "solver=explicit", "stabilisation=0",
        "explicit.target_time_step=2e-7", "explicit.loading_time=0.004")
TARGET = 0.05
AFTER = (0.2, 0.25)  # the strains past every patch's peak: the stress's mean there
DENSE_STRAIN = 0.8  # the densification runs' strain (same rate: 0.25 in 0.004 s)
DENSE_SETS = tuple(s for s in SETS if not s.startswith(("strain=", "explicit.loading_time=")))
DENSE_SETS += (f"strain={DENSE_STRAIN:g}",
               f"explicit.loading_time={0.004 * DENSE_STRAIN / 0.25:g}")
DENSE_PATCHES = (("1,1", 1), ("3,3", 2))  # (cells, ranks) of the densification runs
# the cost target: the paper's dummy-flange variant (touching platen) on 3 x 3
# cells, on 2 cores, under the paper's fastest meso run; the settings of the touching
# runs of validate_meso_explicit.py (20 mm core, to 0.1 at the same rate)
FLANGE_PATCH = ("3,3", 2)
FLANGE_SETS = ("strain=0.1", "solver=explicit", "stabilisation=0",
               "explicit.target_time_step=2e-7", "explicit.loading_time=0.0016",
               "platen=contact", "platen_stick=augmented", "variant=flange")
PAPER_FLANGE_S = 164.9  # Table 2: dummy flanges, Abaqus/Explicit
# (folder, what the dummies do, extra --set items) of the cost target's runs
FLANGE_RUNS = (("flange-3-3", "dummies kept (the case's default)", ()),
               ("flange-3-3-deleted", "dummies deleted at Table 3's fracture strain, as the "
                "paper's were (`dummy_deletion=true`)", ("dummy_deletion=true",)))


class _Row:
    """A run's folder and status, as :func:`status_text` and :func:`curve` read them."""

    def __init__(self, folder: Path, summary: dict):
        self.folder = folder
        self.status = summary.get("status", "not run")
        self.reason = summary.get("reason", "")


def _rms_against(e, s, e_ref, s_ref) -> tuple[float, float]:
    """RMS difference of ``s`` from the reference over their common strains, over the
    reference's peak; and the common strain reached."""
    top = min(e[-1], e_ref[-1])
    grid = np.linspace(0.0, top, 400)
    diff = np.interp(grid, e, s) - np.interp(grid, e_ref, s_ref)
    return float(np.sqrt(np.mean(diff**2)) / np.max(s_ref)), float(top)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--report", action="store_true",
                        help="write the section from the runs in the folder, run none")
    args = parser.parse_args()

    def run(folder: Path, ranks: int, sets: tuple[str, ...]) -> dict:
        return run_or_reuse(folder, ranks, sets, args.report)

    runs = [(cells, ranks, OUT / f"cells-{cells.replace(',', '-')}") for cells, ranks in PATCHES]
    runs = [(c, r, f, run(f, r, (f"cells={c}", *SETS))) for c, r, f in runs]
    dense = [(cells, ranks, OUT / f"densify-{cells.replace(',', '-')}")
             for cells, ranks in DENSE_PATCHES]
    dense = [(c, r, f, run(f, r, (f"cells={c}", *DENSE_SETS))) for c, r, f in dense]
    cells, ranks = FLANGE_PATCH
    flanges = [(OUT / name, run(OUT / name, ranks, (f"cells={cells}", *FLANGE_SETS, *extra)),
                what, extra) for name, what, extra in FLANGE_RUNS]
    done = [r for r in runs if r[3].get("metrics")]
    if not done:
        sys.exit("no run of the study has metrics yet")
    ref_cells, _, ref_folder, ref_summary = done[-1]
    e_ref, s_ref = curve(_Row(ref_folder, ref_summary), ref_summary)
    lines = ["## Meso patch size: is 3 x 3 cells a representative volume? (issue 20)", "",
             "`meso_compression` with fracturing walls that touch each other, bonded "
             "platens, explicit (`" + " ".join(f"--set {x}" for x in SETS) + "`): a 10 mm "
             "core in 4 layers keeps the default element size at half the cost of the "
             "20 mm one; the patches are compared at this one height. Each curve against "
             "the largest patch's: RMS difference of the "
             "nominal stress over their common strains, over that patch's peak (target "
             f"{100 * TARGET:g}%). `python benchmarks/validate_meso_rve.py`; {machine()}.",
             "",
             "| cells | ranks | status | strain reached | elements | stress at 0.05 [MPa] "
             f"| peak [MPa] at strain | mean stress {AFTER[0]:g}-{AFTER[1]:g} [MPa] "
             "| RMS difference from "
             f"{ref_cells.replace(',', ' x ')} | kinetic / internal at most | increments "
             "| wall [s] | commit |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    curves, verdicts = [], []
    for cells, ranks, folder, summary in runs:
        m = summary.get("metrics")
        label = cells.replace(",", " x ")
        if not m:
            lines.append(_missing_row(label, ranks, folder, summary, 10))
            continue
        e, s = curve(_Row(folder, summary), summary)
        band = (e >= AFTER[0]) & (e <= AFTER[1])
        after = float(s[band].mean()) if band.any() else float("nan")
        rms, common = _rms_against(e, s, e_ref, s_ref)
        timing = summary["timing"]
        lines.append(
            f"| {label} | {ranks} | {status_text(_Row(folder, summary), summary)} "
            f"| {m['final_strain']:.4f} | {timing.get('elements', '')} "
            f"| {np.interp(0.05, e, s):.3f} "
            f"| {m['peak_stress_MPa']:.3f} at {m['peak_strain']:.4f} "
            f"| {after:.3f} | {100 * rms:.1f}% (to {common:.3f}) "
            f"| {100 * m['kinetic_to_internal_max']:.1f}% | {timing['time_steps']} "
            f"| {timing['wall_s']:.0f} | {commit(summary)} |")
        curves.append((e, s, f"{label} cells", "-"))
        if folder == ref_folder:
            ref_peak, ref_after = m["peak_stress_MPa"], after
        else:
            verdicts.append((label, rms, common, m["peak_stress_MPa"], after))
    lines.append("")
    for label, rms, common, peak, after in verdicts:
        lines.append(f"- {label} against {ref_cells.replace(',', ' x ')}: RMS difference "
                     f"{100 * rms:.1f}% of the peak over strains to {common:.3f} (target "
                     f"{100 * TARGET:g}%: {'met' if rms <= TARGET else 'missed'}); peak "
                     f"{100 * (peak / ref_peak - 1):+.1f}%, mean stress past it "
                     f"{100 * (after / ref_after - 1):+.1f}%.")
    mass = 1.0 + ref_summary["metrics"].get("mass_added_fraction", 0.0)
    lines += ["- What this does not show: the patch-size curves end at 0.25 (the 1 x 1 "
              f"and 3 x 3 patches go on towards {DENSE_STRAIN:g} below); with the mass scaled "
              f"{mass:.1f}-fold "
              "(the largest patch) to the 2e-7 s step, the kinetic energy exceeds the 5% of "
              "the internal energy that counts as quasi-static where the kinetic column "
              "says so; and the 10 mm core's walls hold to a higher peak at a larger strain "
              "than the 20 mm core's ('fracturing cell walls', 1 x 1), so the answer is for "
              "this height."]
    import forming  # noqa: F401  (PETSc before dolfinx)
    from forming.output import plot_curves

    plot_curves(FIGURES / "meso_rve_stress_strain.png", curves, "nominal strain",
                "nominal stress [MPa]", "Meso compression: patch size (explicit, bonded)")
    lines += ["", "![meso patch size](figures/meso_rve_stress_strain.png)"]
    lines += densification_lines(dense)
    lines += flange_lines(flanges)
    update_section("meso_rve", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))
    cost = ["## `meso_compression`: patch size and cost", "",
            "Written by `python benchmarks/validate_meso_rve.py` (docs/validation.md, 'Meso "
            f"patch size', has the results); {machine()}. Explicit, fracturing walls that "
            "touch, 10 mm core, to 0.25 strain (then two rows to 0.8, and the issue's cost "
            "target's two runs); each run alone on the machine (beside the two runs to 0.8, short "
            "tests for a minute or two). A run resumed from its checkpoint: the cost per "
            "element and increment of its part after the restart.", "",
            "| cells | ranks | status | elements | increments | us per element and increment "
            "| wall [s] |", "|---|---:|---|---:|---:|---:|---:|"]
    for cells, ranks, folder, summary in runs + [(f"{c} to {DENSE_STRAIN:g}", r, f, x)
                                                  for c, r, f, x in dense] + [
            (f"{FLANGE_PATCH[0]} with dummy flanges {'deleted' if extra else 'kept'} "
             "(touching platen; 20 mm core; to 0.1)", FLANGE_PATCH[1], folder, summary)
            for folder, summary, _what, extra in flanges]:
        t = summary.get("timing", {})
        cost.append(f"| {cells.replace(',', ' x ')} | {ranks} "
                    f"| {status_text(_Row(folder, summary), summary)} "
                    f"| {t.get('elements', '')} | {t.get('time_steps', '')} "
                    f"| {us_text(folder, summary)} | {wall_text(folder, summary)} |")
    update_section("meso_rve_cost", "\n".join(cost), PERFORMANCE_MD)
    print("\n".join(cost))


def _platen_speed(share: float) -> float:
    """The smooth-step load's speed over its mean where it has reached ``share``."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid**3 * (10 - 15 * mid + 6 * mid * mid) < share else (lo, mid)
    x = 0.5 * (lo + hi)
    return 30.0 * x * x * (1.0 - x) ** 2


def run_or_reuse(folder: Path, ranks: int, sets: tuple[str, ...], report: bool) -> dict:
    """A ``meso_compression`` run's summary: the one in ``folder`` if that run ended (or
    with ``report``), else from running it now."""
    summary = read_summary(folder)
    if report or summary.get("status") not in (None, "running"):
        return summary
    return run_case_process("meso_compression", folder, ranks, sets=sets, allow_failure=True)


def _missing_row(label: str, ranks: int, folder: Path, summary: dict, blanks: int) -> str:
    """A table row for a run without metrics: its status, then ``blanks`` empty cells."""
    return (f"| {label} | {ranks} | {status_text(_Row(folder, summary), summary)} |"
            + " |" * blanks)


def _history(folder: Path) -> np.ndarray:
    """A run's ``history.csv`` as a structured array."""
    return np.atleast_1d(np.genfromtxt(folder / "history.csv", delimiter=",", names=True))


def _before_restart(h: np.ndarray, summary: dict) -> np.ndarray | None:
    """Rows of a resumed run's history up to its checkpoint (None: not resumed)."""
    back = summary.get("restarted_from")
    return None if not back else h["t"] <= back["t"] + 1e-12


def _restart_strain(summary: dict) -> float:
    """The nominal strain at which a resumed run was resumed."""
    return summary["restarted_from"]["t"] * summary["parameters"]["strain"]


def us_text(folder: Path, summary: dict) -> str:
    """Microseconds per element and increment; of a resumed run, of its part after the
    restart (its ``integration_s``) over the increments of that part."""
    t = summary.get("timing", {})
    if not summary.get("restarted_from") or "integration_s" not in t:
        return f"{t.get('us_per_element_increment', float('nan')):.1f}"
    h = _history(folder)
    run = np.sum(h["time_increments"][~_before_restart(h, summary)])
    return f"{1e6 * t['integration_s'] / (run * t['elements']):.1f}"


def flange_lines(flanges: list[tuple[Path, dict, str, tuple]]) -> list[str]:
    """The issue's cost target: the dummy-flange variant on :data:`FLANGE_PATCH`."""
    cells, ranks = FLANGE_PATCH
    label = cells.replace(",", " x ")
    lines = ["", f"### Cost: the dummy-flange variant on {label} cells", "",
             f"The issue's target: `meso_compression` on {label} cells with the paper's dummy "
             f"flanges under {PAPER_FLANGE_S} s on 2 cores (the paper's fastest meso run, "
             "Table 2, on a patch, mesh and machine it does not give). The settings of the "
             "touching-platen runs of 'explicit runs, walls that touch' (`"
             + " ".join(f"--set {x}" for x in (f"cells={cells}", *FLANGE_SETS))
             + f"`), on {ranks} ranks.", ""]
    for folder, summary, what, _extra in flanges:
        t = summary.get("timing")
        if not t:
            lines.append(f"- {what}: not run ({summary.get('status', 'no summary')}).")
            continue
        m = summary.get("metrics", {})
        lines.append(
            f"- {what}: {status_text(_Row(folder, summary), summary)}; strain reached "
            f"{m.get('final_strain', float('nan')):.3f}, peak "
            f"{m.get('peak_stress_MPa', float('nan')):.2f} MPa at "
            f"{m.get('peak_strain', float('nan')):.3f}, kinetic energy up to "
            f"{100 * m.get('kinetic_to_internal_max', float('nan')):.1f}% of the internal. "
            f"Wall time {t['wall_s']:.0f} s on {ranks} ranks, "
            f"{t['wall_s'] / PAPER_FLANGE_S:.1f} times the paper's {PAPER_FLANGE_S} s: "
            f"{t['time_steps']} increments of {t['elements']} elements (walls and "
            f"flanges), {us_text(folder, summary)} us per element and increment.")
    return lines


def wall_text(folder: Path, summary: dict) -> str:
    """A run's wall time; for a run resumed from a checkpoint, the sum of its output
    intervals' (``step_wall_s``, start-up left out) and where it was resumed."""
    if not summary.get("restarted_from"):
        return f"{summary['timing']['wall_s']:.0f}"
    h = _history(folder)
    before = _before_restart(h, summary)
    return (f"{np.sum(h['step_wall_s']):.0f} ({np.sum(h['step_wall_s'][before]):.0f} to "
            f"{_restart_strain(summary):.2f}, then resumed)")


def _rise_text(e: np.ndarray, s: np.ndarray, peak_strain: float) -> str:
    """Where the stress is lowest after the peak, and highest after that."""
    after = np.flatnonzero(e > peak_strain)
    low = after[int(np.argmin(s[after]))]
    high = low + int(np.argmax(s[low:]))
    return (f"; after the peak the stress falls to {s[low]:.3f} MPa at {e[low]:.3f} and "
            f"rises again to {s[high]:.3f} MPa at {e[high]:.3f}"
            + (f", to end at {s[-1]:.3f} MPa" if high < len(s) - 1 else ""))


def _resumed_text(summary: dict, h: np.ndarray) -> str:
    """What a resumed run's output intervals say of the contact search's cost."""
    before = _before_restart(h, summary)
    if before is None:
        return (f" Its last output interval took {h['step_wall_s'][-1]:.0f} s against "
                f"{np.median(h['step_wall_s']):.0f} s for the median one.")
    last = h["step_wall_s"][before][-1]
    return (f" It was stopped by hand at {_restart_strain(summary):.2f} strain (its last "
            f"output interval there took {last:.0f} s against "
            f"{np.median(h['step_wall_s'][before]):.0f} s for the median one, much of it in "
            "searches of the self-contact's whole candidate list) and resumed from its "
            f"checkpoint at {commit(summary)}, whose search redoes only the pairs of the "
            "nodes that moved (docs/theory.md §15): its intervals after the restart took "
            f"{np.median(h['step_wall_s'][~before]):.0f} s (median), the last "
            f"{h['step_wall_s'][-1]:.0f} s for {int(h['time_increments'][-1])} increments "
            f"(the median one {int(np.median(h['time_increments'][~before]))}: the "
            "smooth-step load slows the platen to rest at its end, so its last output "
            "interval spans the most time).")


def densification_lines(dense: list[tuple[str, int, Path, dict]]) -> list[str]:
    """The patches to :data:`DENSE_STRAIN`: their regions, the 1 x 1's story, a figure."""
    lines = ["", f"### To densification (to {DENSE_STRAIN:g})", "",
             "The same core and rate, `--set cells=N,M --set strain=0.8 --set "
             "explicit.loading_time=0.0128`. Plateau: the mean stress from twice the peak "
             "strain to 0.5 (or the end); densification onset: the first strain past the "
             "curve's lowest point after the peak where the stress exceeds twice the "
             "plateau.", "",
             "| cells | ranks | status | peak [MPa] at strain | plateau [MPa] "
             "| densification onset | stress at 0.6 / 0.7 / 0.75 [MPa] | strain reached "
             "| deepest wall overlap [mm] | kinetic / internal at most | increments "
             "| wall [s] | commit |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    curves, found = [], {}
    for cells, ranks, folder, summary in dense:
        m = summary.get("metrics")
        label = cells.replace(",", " x ")
        if not m:
            lines.append(_missing_row(label, ranks, folder, summary, 10))
            continue
        e, s = curve(_Row(folder, summary), summary)
        plateau, onset = regions(e, s, m["peak_strain"])
        at = [float(np.interp(x, e, s)) if e[-1] >= x else float("nan")
              for x in (0.6, 0.7, 0.75)]
        t = summary["timing"]
        lines.append(
            f"| {label} | {ranks} | {status_text(_Row(folder, summary), summary)} "
            f"| {m['peak_stress_MPa']:.3f} at {m['peak_strain']:.4f} | {plateau:.3f} "
            f"| {onset:.3f} | {at[0]:.3f} / {at[1]:.3f} / {at[2]:.3f} "
            f"| {m['final_strain']:.4f} | {m.get('self_contact_penetration_max_mm', 0):.4f} "
            f"| {100 * m['kinetic_to_internal_max']:.1f}% | {t['time_steps']} "
            f"| {wall_text(folder, summary)} | {commit(summary)} |")
        curves.append((e, s, f"{label} cells, 10 mm core (meso, explicit)", "-"))
        found[cells] = (folder, summary, e, s, plateau, onset)
    lines.append("")
    if "1,1" not in found:
        return lines
    folder, summary, e, s, plateau, onset = found["1,1"]
    m, t = summary["metrics"], summary["timing"]
    h = _history(folder)
    pairs = [c for c in h.dtype.names if c.startswith("self_contact") and c.endswith("pairs")]
    short = OUT / "cells-1-1"
    short_summary = read_summary(short)
    import forming  # noqa: F401  (PETSc before dolfinx)
    from forming.materials.library import honeycomb_core
    from forming.output import plot_curves

    macro = honeycomb_core("isotropic").curve
    lines += [f"- The three regions of the paper's Fig. 6: linear to the peak "
              f"({m['peak_stress_MPa']:.2f} MPa at {m['peak_strain']:.3f}), a plateau "
              f"({plateau:.3f} MPa), densification from {onset:.3f}, where the folds meet: "
              + (f"{int(h[pairs[0]][-1])} wall nodes against another wall's face at the end "
                 f"({int(h[pairs[0]][len(h) // 2])} at half the stroke)" if pairs else "")
              + f". The macro model's curve (an estimate of the measured core, "
              f"docs/materials.md) has its plateau at {float(macro.interpolate(0.3)):.2f} MPa "
              f"and rises to {float(macro.interpolate(DENSE_STRAIN)):.2f} MPa at "
              f"{DENSE_STRAIN:g}: the walls of Table 1 are stronger than the real core "
              "here as in the modulus and the peak."]
    if "3,3" in found:
        folder3, summary3, e3, s3, plateau3, onset3 = found["3,3"]
        h3 = _history(folder3)
        top = min(e[-1], e3[-1])
        grid3 = np.linspace(2 * m["peak_strain"], top, 200)
        gap = (float(np.sqrt(np.mean((np.interp(grid3, e, s) - np.interp(grid3, e3, s3))**2)))
               if top > grid3[0] else float("nan"))
        lines.append(f"- 3 x 3 cells: plateau {plateau3:.3f} MPa against {plateau:.3f}; "
                     + ("densification not reached" if np.isnan(onset3) else
                        f"densification from {onset3:.3f}")
                     + f" (the run reached {e3[-1]:.3f}: {summary3['status']})"
                     + _rise_text(e3, s3, summary3["metrics"]["peak_strain"])
                     + f". Past twice "
                     f"the 1 x 1 peak strain, to {top:.3f}, the two curves are {gap:.3f} MPa "
                     "apart (RMS)." + _resumed_text(summary3, h3))
    if short_summary.get("metrics"):
        sm = short_summary["metrics"]
        speed = [_platen_speed(sm["peak_strain"] / sm["final_strain"]),
                 _platen_speed(m["peak_strain"] / DENSE_STRAIN)]
        lines.append(f"- The peak depends on the platen's speed: the 1 x 1 run to 0.25 "
                     f"above peaked at {sm['peak_stress_MPa']:.2f} MPa, this one at "
                     f"{m['peak_stress_MPa']:.2f}. Both have the same mean strain rate, but "
                     "the smooth-step load puts the platen at "
                     f"{speed[0]:.2f} and {speed[1]:.2f} times its mean speed at their "
                     "peaks; with the mass scaled about 9.5-fold the walls' inertia adds to "
                     "the peak. How far below both a quasi-static peak lies was not "
                     "measured.")
    lines.append(f"- Walls in contact: the deepest overlap, "
                 f"{m.get('self_contact_penetration_max_mm', 0):.3f} mm, reached the search "
                 "depth (half the smallest element edge): a node pressed deeper than that in "
                 "one increment is no longer held (docs/theory.md §15).")
    shape = folder / "final_shape.npz"
    if shape.is_file():
        with np.load(shape) as data:
            x0 = data[[k for k in data.files if k.endswith("_X")][0]]
            x = x0 + data[[k for k in data.files if k.endswith("_u")][0]]
        flung = int(np.count_nonzero(((x < x0.min(axis=0) - 2.0)
                                      | (x > x0.max(axis=0) + 2.0)).any(axis=1)))
        walls = np.round(h["step_wall_s"][-1], 0)
        lines.append(f"- {flung} of the {len(x0)} wall nodes ended more than 2 mm outside "
                     f"the patch (the farthest {np.max(np.linalg.norm(x - x0, axis=1)):.0f} "
                     "mm away). They hang on cracked cells, many of whose points have "
                     "eroded while the rest are damaged, which the default "
                     "`wall_deletion=all` keeps until every point has. "
                     "They carry almost no stiffness and fly off; their motion moves the "
                     "self-contact's candidate list past its margin every few increments. "
                     f"At {commit(summary)} the whole list was searched again each time "
                     f"(the last interval took {walls:.0f} s of the {t['wall_s']:.0f}); "
                     "now only those nodes' pairs are (docs/performance.md, 'Self-contact "
                     "late in a crushing').")
    grid = np.linspace(0.0, DENSE_STRAIN, 200)
    plot_curves(FIGURES / "meso_densification.png",
                curves + [(grid, macro.interpolate(grid),
                           "macro model's C365 curve (estimate of Fig. 6)", "k:")],
                "nominal strain", "nominal stress [MPa]",
                "Meso compression to densification (explicit, bonded)")
    return lines + ["", "![meso compression to densification](figures/meso_densification.png)"]


if __name__ == "__main__":
    main()
