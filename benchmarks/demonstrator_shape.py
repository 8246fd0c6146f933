"""Why the demonstrator's explicit and implicit final shapes differ (issue 18, item 5).

``forming compare demonstrator`` measures the final shape as the RMS distance between
the two runs' nodes, over the core's thickness (target 2%). On the 60 mm mesh it missed
(3.9%). This study separates what moves the final positions. On the 60 mm mesh, each run
serial:

- the implicit run's skin-core stabilising spring (the default 10⁻³ of the penalty, and
  10⁻⁴), each at the default largest load step (0.01) and at half of it;
- the explicit run's loading time (the default 0.05 s, 0.1 s and 0.2 s).

Every run is compared node by node with the finest implicit run (spring 10⁻⁴, half
step): the RMS distance over the thickness, its parts along z (where the formed surface
lies) and in plan (where the material points lie on it), each body's RMS, and the
closing force, blank-edge draw-in, skin-core slip and wall time. On the default 30 mm
mesh, on 2 ranks: the default implicit run, the one with the 10⁻⁴ spring, and the
explicit runs over 0.05 s (the default) and 0.1 s, compared with the default implicit
run. ``forming compare`` on
each mesh's two default runs gives the issue's figures.

Runs are kept in ``--work`` (``results/demonstrator_shape``); a completed run there is
reused. ``--write`` writes the ``demonstrator_shape`` section of docs/validation.md.

Run alone: ``python benchmarks/demonstrator_shape.py --write`` (about 90 minutes on 2
cores from nothing).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from _report import REPO, Run, final_shape, machine, read_summary, run_case_process, update_section

sys.path.insert(0, str(REPO))
from forming.compare import shape_differences  # noqa: E402

VALIDATION_MD = REPO / "docs" / "validation.md"
THICKNESS = 20.0  # the core's [mm]: the compare's reference length
# the study ran with the upper tool 1 mm above the blank, the l2 line search, the skin
# springs at 1e-3, the stick slip at 0.005 and the explicit loading over 0.05 s (the
# case's defaults then; a row's own settings override these)
FORMER = ("clearance=1", "newton.line_search=l2", "skin_stabilisation=1e-3",
          "skin_elastic_slip=5e-3", "newton.spring_release=1", "explicit.loading_time=0.05")


@dataclass(frozen=True)
class Group:
    """Runs on one mesh and rank count, each compared with ``reference``."""

    title: str
    folder: str
    mesh: tuple[str, ...]
    ranks: int
    reference: str
    runs: tuple[Run, ...]


GROUPS = (
    Group("60 mm mesh, serial", "mesh60", ("element_size=60", *FORMER), 1,
          "implicit_spring1e-4_half", (
        Run("implicit, spring 1e-3, step 0.01 (defaults)", "implicit"),
        Run("implicit, spring 1e-3, step 0.005", "implicit_half", ("max_step=0.005",)),
        Run("implicit, spring 1e-4, step 0.01", "implicit_spring1e-4",
            ("skin_stabilisation=1e-4",)),
        Run("implicit, spring 1e-4, step 0.005 (reference)", "implicit_spring1e-4_half",
            ("skin_stabilisation=1e-4", "max_step=0.005")),
        Run("explicit, 0.05 s (default)", "explicit", ("solver=explicit",)),
        Run("explicit, 0.1 s", "explicit_0.1s", ("solver=explicit", "explicit.loading_time=0.1")),
        Run("explicit, 0.2 s", "explicit_0.2s", ("solver=explicit", "explicit.loading_time=0.2")),
    )),
    Group("30 mm mesh (the default), 2 ranks", "mesh30", ("element_size=30", *FORMER), 2,
          "implicit", (
        Run("implicit, spring 1e-3 (defaults, reference)", "implicit"),
        Run("implicit, spring 1e-4", "implicit_spring1e-4", ("skin_stabilisation=1e-4",)),
        Run("explicit, 0.05 s (default)", "explicit", ("solver=explicit",)),
        Run("explicit, 0.1 s", "explicit_0.1s", ("solver=explicit", "explicit.loading_time=0.1")),
    )),
)


def _run(group: Group, run: Run, work: Path) -> dict:
    folder = work / group.folder / run.slug
    if read_summary(folder).get("status") != "completed":
        run_case_process("demonstrator", folder, ranks=group.ranks,
                         sets=(*group.mesh, *run.sets), allow_failure=True)
    return read_summary(folder)


def _row(run: Run, summary: dict, ref: dict[str, np.ndarray], folder: Path) -> str:
    if summary.get("status") != "completed":
        return f"| {run.label} | {summary.get('status', 'not run')} |" + " |" * 10
    m, t = summary["metrics"], summary["timing"]
    f = shape_differences(ref, final_shape(folder), THICKNESS)[0]
    stiffened = t.get("spring_stiffened_steps", 0)
    return (f"| {run.label} | {f['shape_rms_diff_rel_thickness']:.2%} | "
            f"{f['shape_rms_diff_mm_z']:.3f} | {f['shape_rms_diff_mm_plan']:.3f} | "
            f"{f['shape_rms_diff_mm_core']:.3f} | {f['shape_rms_diff_mm_skin_bottom']:.3f} | "
            f"{f['shape_rms_diff_mm_skin_top']:.3f} | {m['closing_force_max_N'] / 1e3:.2f} | "
            f"{m['edge_draw_in_max_mm']:.2f} | {m['skin_core_slip_max_mm']:.2f} | "
            f"{t.get('rejected_steps', 0)} / {stiffened} | {t['wall_s']:.0f} |")


def _pair(folder: Path, a: str, b: str) -> str:
    f = shape_differences(final_shape(folder / a), final_shape(folder / b), THICKNESS)[0]
    return (f"{f['shape_rms_diff_rel_thickness']:.2%} (along z {f['shape_rms_diff_mm_z']:.3f} "
            f"mm, in plan {f['shape_rms_diff_mm_plan']:.3f} mm)")


def _compare(group: Group, work: Path) -> str:
    folder = work / group.folder
    sets = [a for m in group.mesh for a in ("--set", m)]
    cmd = [str(Path(sys.executable).parent / "forming"), "compare", "demonstrator", *sets,
           "--out", str(folder), "--reuse"]
    subprocess.run(cmd, cwd=REPO, check=True, capture_output=True, text=True)
    c = json.loads((folder / "compare.json").read_text())
    return (f"`forming compare demonstrator {' '.join(sets)} --reuse` on the two default "
            f"runs: force RMS difference {c['force_rms_diff_rel']:.2%} of the peak (target "
            f"3%), final shape {c['shape_rms_diff_rel_thickness']:.2%} of the thickness "
            f"(target 2%): along z {c['shape_rms_diff_mm_z']:.3f} mm, in plan "
            f"{c['shape_rms_diff_mm_plan']:.3f} mm; the explicit run's kinetic energy at most "
            f"{c['kinetic_to_internal_max']:.2%} of the internal; targets met: "
            f"{'yes' if c['meets_targets'] else 'no'}.")


HEADER = ("| run | RMS / thickness | along z [mm] | in plan [mm] | core [mm] | bottom skin "
          "[mm] | top skin [mm] | closing force [kN] | draw-in [mm] | skin-core slip [mm] | "
          "cut / stiffened steps | wall [s] |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def report(work: Path, summaries: dict[tuple[str, str], dict]) -> str:
    """The ``demonstrator_shape`` section from the runs in ``work``."""
    where = work.relative_to(REPO) if work.is_relative_to(REPO) else work
    lines = [f"Written by `python benchmarks/demonstrator_shape.py --write` (runs in "
             f"`{where}`: run one at a time by the script, or reused from there as they "
             f"are; {machine()}). Each run against its group's reference, node by node: the "
             "RMS distance over the 20 mm core, its parts along z and in plan, and each "
             "body's RMS. Cut steps: rejected steps; stiffened: steps run with the "
             "stabilising springs stiffened (docs/theory.md §11). Every run with "
             f"`{' '.join(FORMER)}`, as the study was made (\"defaults\": the case's other "
             "defaults; since 2026-11-28 the upper tool starts on the blank, docs/theory.md "
             "§16)."]
    for g in GROUPS:
        folder = work / g.folder
        ref = final_shape(folder / g.reference)
        lines += ["", f"**{g.title}**", "", HEADER,
                  *(_row(r, summaries[g.folder, r.slug], ref, folder / r.slug)
                    for r in g.runs), ""]
        slugs = {r.slug for r in g.runs}
        if {"implicit_half", "explicit_0.1s"} <= slugs:
            lines += [
                f"- the implicit spring, 10⁻³ against 10⁻⁴ (step 0.01): "
                f"{_pair(folder, 'implicit', 'implicit_spring1e-4')};",
                f"- halving the implicit step at 10⁻³: "
                f"{_pair(folder, 'implicit', 'implicit_half')}; at 10⁻⁴: "
                f"{_pair(folder, 'implicit_spring1e-4', 'implicit_spring1e-4_half')};",
                f"- the explicit loading time, 0.05 against 0.1 s: "
                f"{_pair(folder, 'explicit', 'explicit_0.1s')}; 0.1 against 0.2 s: "
                f"{_pair(folder, 'explicit_0.1s', 'explicit_0.2s')}.", ""]
        elif "explicit_0.1s" in slugs:
            lines += [
                f"- the explicit loading time, 0.05 against 0.1 s: "
                f"{_pair(folder, 'explicit', 'explicit_0.1s')};",
                f"- against the implicit run with the 10⁻⁴ spring: the explicit run over "
                f"0.05 s {_pair(folder, 'implicit_spring1e-4', 'explicit')}, over 0.1 s "
                f"{_pair(folder, 'implicit_spring1e-4', 'explicit_0.1s')}.", ""]
        lines.append(_compare(g, work))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=REPO / "results" / "demonstrator_shape")
    parser.add_argument("--write", action="store_true", help="write docs/validation.md")
    args = parser.parse_args()
    work = args.work.resolve()
    summaries = {(g.folder, r.slug): _run(g, r, work) for g in GROUPS for r in g.runs}
    body = report(work, summaries)
    print(body)
    if args.write:
        update_section("demonstrator_shape", body, VALIDATION_MD)


if __name__ == "__main__":
    main()
