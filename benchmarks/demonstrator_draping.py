"""Where the demonstrator's explicit and implicit skins part: the draping phase (issue 18).

``forming compare demonstrator`` misses its shape target (2% of the core's thickness)
in the skins' in-plane positions. This study follows both solvers through the stroke on
the 60 mm mesh, serial, with the case's defaults otherwise (the upper tool starting on
the blank):

- the implicit run's two regularisations of the skin-core friction: the stabilising
  spring (10⁻³ and 10⁻⁴ of the penalty) and the elastic slip of its stick law (0.005,
  5·10⁻⁴ and 5·10⁻⁵ of the facet edge);
- the explicit run's loading time (0.05 s, 0.1 s and 0.2 s).

The case's defaults are 10⁻³, 0.005 and 0.05 s; the runs name their settings, so that
they stay the same runs if the defaults change (the implicit runs keep the l2 line search
they were made with; the case takes full Newton steps since 2026-11-29).

Every run is compared node by node with the implicit run with the 10⁻⁴ spring and the
5·10⁻⁴ elastic slip (the reference: the next tenfold smaller slip moves it by less than
1%). Beside the final figures it reads each run's ParaView fields at two moments of the
load: at 40% (the blank bent into the lower tool, nothing pressed yet) the skins' mean
distance from the core's faces along z (a bottom skin below the core, a top skin above
it, mean over their nodes), and at 50% the skins' in-plane distance from the reference
run at the same load (its fields interpolated between its output steps).

Runs are kept in ``--work`` (``results/demonstrator_draping``); a completed run there is
reused. ``--write`` writes the ``demonstrator_draping`` section of docs/validation.md.

Run alone: ``python benchmarks/demonstrator_draping.py --write`` (about 35 minutes on 2
cores from nothing).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from _report import REPO, Run, final_shape, machine, read_summary, run_case_process, update_section

sys.path.insert(0, str(REPO))
from forming.compare import shape_differences  # noqa: E402
from forming.fields import FieldSeries  # noqa: E402

VALIDATION_MD = REPO / "docs" / "validation.md"
THICKNESS = 20.0  # the core's [mm]: the compare's reference length
PLY = 0.4  # the case's ply thickness [mm]
MESH = ("element_size=60",)
REFERENCE = "implicit_spring1e-4_slip5e-4"
SEPARATION_AT = 0.4  # load parameter: the blank bent, nothing pressed yet
PLAN_AT = 0.5  # load parameter: before the tools press the skins


# the study was made with the l2 line search and one solve per step, the case's
# defaults until 2026-11-29
FORMER = ("newton.line_search=l2", "newton.spring_release=1")
RUNS = (
    Run("implicit, spring 1e-3, slip 5e-3 (defaults)", "implicit",
        ("skin_stabilisation=1e-3", "skin_elastic_slip=5e-3", *FORMER)),
    Run("implicit, spring 1e-4, slip 5e-3", "implicit_spring1e-4",
        ("skin_stabilisation=1e-4", "skin_elastic_slip=5e-3", *FORMER)),
    Run("implicit, spring 1e-4, slip 5e-4 (reference)", REFERENCE,
        ("skin_stabilisation=1e-4", "skin_elastic_slip=5e-4", *FORMER)),
    Run("implicit, spring 1e-4, slip 5e-5", "implicit_spring1e-4_slip5e-5",
        ("skin_stabilisation=1e-4", "skin_elastic_slip=5e-5", *FORMER)),
    Run("explicit, 0.05 s (default)", "explicit",
        ("solver=explicit", "explicit.loading_time=0.05")),
    Run("explicit, 0.1 s", "explicit_0.1s", ("solver=explicit", "explicit.loading_time=0.1")),
    Run("explicit, 0.2 s", "explicit_0.2s", ("solver=explicit", "explicit.loading_time=0.2")),
)


def _run(run: Run, work: Path) -> dict:
    folder = work / run.slug
    if read_summary(folder).get("status") != "completed":
        run_case_process("demonstrator", folder, sets=(*MESH, *run.sets), allow_failure=True)
    return read_summary(folder)


def part_nodes(reference: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each body's nodes that end inside the trim line in the reference run: the part
    (outside it is the scrap, the blank's overhang that no tool holds)."""
    from forming.demonstrator.setup import Part, inside_trim

    part = Part.from_params(None, None, 1.0, None, None, THICKNESS + 2 * PLY)
    return {k[:-2]: inside_trim(part, (reference[k] + reference[f"{k[:-2]}_u"])[:, :2])
            for k in reference if k.endswith("_X") and f"{k[:-2]}_u" in reference}


def rms_on(keep: dict[str, np.ndarray], reference: dict[str, np.ndarray],
           other: dict[str, np.ndarray]) -> float:
    """RMS nodal distance between two final shapes over the nodes ``keep``, over the core's
    thickness."""
    d = [np.linalg.norm(other[f"{n}_u"] - reference[f"{n}_u"], axis=1)[k]
         for n, k in keep.items()]
    return float(np.sqrt(np.mean(np.concatenate(d) ** 2)) / THICKNESS)


def _series(folder: Path, body: str) -> FieldSeries:
    return FieldSeries(folder / f"displacement_{body}.bp")


def _at(series: FieldSeries, t: float) -> np.ndarray:
    """A series' displacement at load ``t``, linear between its output steps."""
    i = int(np.clip(np.searchsorted(series.times, t), 1, len(series.times) - 1))
    t0, t1 = series.times[i - 1], series.times[i]
    w = float(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))
    return (1 - w) * series.values("u", i - 1) + w * series.values("u", i)


def separation(folder: Path, t: float) -> tuple[float, float]:
    """Mean distance along z of the bottom skin below and the top skin above the core's
    faces at load ``t`` [mm] (mean displacements over each set of nodes)."""
    core = _series(folder, "core")
    z0 = core.points(0)[:, 2]
    uc = _at(core, t)[:, 2]
    bottom = uc[z0 < z0.min() + 1e-6].mean() - _at(_series(folder, "skin_bottom"), t)[:, 2].mean()
    top = _at(_series(folder, "skin_top"), t)[:, 2].mean() - uc[z0 > z0.max() - 1e-6].mean()
    return float(bottom), float(top)


def draping_kinetic(folder: Path, start: float = 0.3) -> str:
    """An explicit run's largest kinetic over internal energy from load ``start`` on (the
    draping included: the run's own check counts only rows whose internal energy is at
    least 5% of its largest, which the crushing's energy leaves out)."""
    h = np.genfromtxt(folder / "history.csv", delimiter=",", names=True)
    if "energy_kinetic_Nmm" not in h.dtype.names:
        return ""
    rows = (h["t"] >= start - 1e-9) & (h["energy_internal_Nmm"] > 0)
    return f"{np.max(h['energy_kinetic_Nmm'][rows] / h['energy_internal_Nmm'][rows]):.1%}"


def plan_apart(folder: Path, reference: Path, t: float) -> float:
    """RMS in-plane distance of both skins' nodes from the reference run's at load ``t``."""
    d = [(_at(_series(folder, b), t) - _at(_series(reference, b), t))[:, :2]
         for b in ("skin_bottom", "skin_top")]
    return float(np.sqrt(np.mean(np.sum(np.concatenate(d) ** 2, axis=1))))


HEADER = ("| run | RMS / thickness | inside the trim line | along z [mm] | in plan [mm] | "
          "core [mm] | bottom skin [mm] | top skin [mm] | skins off the core at 40%: "
          "bottom / top [mm] | skins in "
          "plan at 50% [mm] | kinetic / internal from 30% of the load | closing force [kN] | "
          "Newton iterations or increments | wall [s] |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def _row(run: Run, summary: dict, work: Path, ref_shape: dict[str, np.ndarray],
         part: dict[str, np.ndarray]) -> str:
    if summary.get("status") != "completed":
        return f"| {run.label} | {summary.get('status', 'not run')} |" + " |" * 12
    folder, ref = work / run.slug, work / REFERENCE
    m, t = summary["metrics"], summary["timing"]
    shape = final_shape(folder)
    f = shape_differences(ref_shape, shape, THICKNESS)[0]
    trim = rms_on(part, ref_shape, shape)
    bottom, top = separation(folder, SEPARATION_AT)
    work_done = t.get("newton_iterations") or t.get("time_steps", "")
    return (f"| {run.label} | {f['shape_rms_diff_rel_thickness']:.2%} | {trim:.2%} | "
            f"{f['shape_rms_diff_mm_z']:.3f} | {f['shape_rms_diff_mm_plan']:.3f} | "
            f"{f['shape_rms_diff_mm_core']:.3f} | {f['shape_rms_diff_mm_skin_bottom']:.3f} | "
            f"{f['shape_rms_diff_mm_skin_top']:.3f} | {bottom:.2f} / {top:.2f} | "
            f"{plan_apart(folder, ref, PLAN_AT):.3f} | {draping_kinetic(folder)} | "
            f"{m['closing_force_max_N'] / 1e3:.2f} | "
            f"{work_done} | {t['wall_s']:.0f} |")


def report(work: Path, summaries: dict[str, dict]) -> str:
    """The ``demonstrator_draping`` section from the runs in ``work``."""
    where = work.relative_to(REPO) if work.is_relative_to(REPO) else work
    ref_shape = final_shape(work / REFERENCE)
    part = part_nodes(ref_shape)
    return "\n".join([
        f"Written by `python benchmarks/demonstrator_draping.py --write` (runs in `{where}`, "
        f"reused from there as they are; {machine()}). `cases/demonstrator.py --set "
        f"{' '.join(MESH)}` serial, the case's defaults otherwise; each run against the "
        "reference node by node (the RMS distance over the 20 mm core, over the nodes that "
        "end inside the trim line, the parts along z and in plan, each body's RMS). 'Skins "
        "off the core at 40%': at 40% of the load "
        "the bottom skin's mean z below the core's bottom face and the top skin's above "
        "its top face (the implicit skins start on the core). 'Skins in plan at 50%': both "
        "skins' RMS in-plane distance from the reference at half the load.",
        "", HEADER, *(_row(r, summaries[r.slug], work, ref_shape, part) for r in RUNS), ""])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=REPO / "results" / "demonstrator_draping")
    parser.add_argument("--write", action="store_true", help="write docs/validation.md")
    args = parser.parse_args()
    work = args.work.resolve()
    summaries = {r.slug: _run(r, work) for r in RUNS}
    body = report(work, summaries)
    print(body)
    if args.write:
        update_section("demonstrator_draping", body, VALIDATION_MD)


if __name__ == "__main__":
    main()
