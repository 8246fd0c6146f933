"""MUMPS's LU in double against single precision refined in double, in whole runs.

Each scene is run with ``newton.lu_precision=double`` and ``=single`` alternated
``--repeats`` times (so that the machine's drift falls on both alike): wall time,
Newton iterations, the per-iteration split (kernel, assembly, linear solve), the
single-precision runs' refinement iterations per solve and double-precision fallbacks
(:class:`forming.solver.linear.RefinedLU`), and the answer (punch force, crushed volume),
which must not move beyond what the linear tolerance (1e-10) allows on the same Newton
path. ``core_crushing`` follows round-off (docs/validation.md), so its two runs may take
different paths. Writes docs/performance.md's ``lu_precision`` section.

Run: ``python benchmarks/lu_precision.py`` (about 20 minutes on 2 cores, nothing else
running); ``--quick`` leaves out the 53,391-unknown sandwich (about 10 minutes less).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from dataclasses import dataclass
from pathlib import Path

from _report import alternate, machine, update_section

CHOICES = ("double", "single")


@dataclass(frozen=True)
class Scene:
    """A run of the benchmark: label, case, settings and ranks."""

    label: str
    case: str
    sets: tuple[str, ...]
    ranks: int = 1
    repeats: int | None = None  # None: the command line's


SANDWICH = ("skins=true", "skin_contact=small", "blank_holder=true")
SCENES = (
    Scene("hemisphere with holder, 12 x 12 x 3", "hemisphere",
          ("cells=12,12,3", "blank_holder=true")),
    Scene("hemisphere without holder, 20 x 20 x 4", "hemisphere", ("blank_holder=false",)),
    Scene("hemisphere with holder, 20 x 20 x 4", "hemisphere", ("blank_holder=true",)),
    Scene("hemisphere without holder, 20 x 20 x 4", "hemisphere", ("blank_holder=false",), 2),
    Scene("sandwich hemisphere, 8 x 8 x 2", "hemisphere", (*SANDWICH, "cells=8,8,2")),
    Scene("core_crushing", "core_crushing", ()),
    Scene("sandwich hemisphere, 18 x 18 x 4, first 0.2 mm", "hemisphere",
          (*SANDWICH, "cells=18,18,4", "stroke=0.2", "max_step=1")),
    Scene("sandwich hemisphere, 36 x 36 x 8, first 0.2 mm", "hemisphere",
          (*SANDWICH, "cells=36,36,8", "stroke=0.2", "max_step=1"), repeats=1),
)


def _row(scene: Scene, choice: str, rs: list[dict]) -> str:
    t, m = rs[-1]["timing"], rs[-1]["metrics"]
    split = t["per_iteration_ms"]
    refine = "-"
    if choice == "single":
        refine = (f"{t['refinement_iterations'] / max(t['linear_solves'], 1):.1f} / "
                  f"{t['exact_fallbacks']}")
    walls = ", ".join(f"{r['timing']['wall_s'] - r['timing']['jit_s']:.1f}" for r in rs)
    unknowns = rs[-1].get("mesh", {}).get("dofs", "")
    return (f"| {scene.label} | {unknowns} | {scene.ranks} | {choice} | {walls} | "
            f"{t['newton_iterations']} | {t['steps']} ({t['rejected_steps']}) | "
            f"{split['kernel']:.1f} / {split['assembly']:.1f} / {split['linear_solve']:.1f} | "
            f"{refine} | {m['punch_force_max_N']:.10g} | {m['crushed_volume_mm3']:.8g} |")


def _verdict(scene: Scene, runs: dict[str, list[dict]]) -> str:
    def wall(r: dict) -> float:
        return r["timing"]["wall_s"] - r["timing"]["jit_s"]

    def split(c: str) -> float:
        return statistics.median(r["timing"]["per_iteration_ms"]["linear_solve"]
                                 for r in runs[c])

    med = {c: statistics.median(wall(r) for r in runs[c]) for c in CHOICES}
    a, b = (runs[c][-1] for c in CHOICES)
    same = a["timing"]["newton_iterations"] == b["timing"]["newton_iterations"]
    df = abs(a["metrics"]["punch_force_max_N"] - b["metrics"]["punch_force_max_N"])
    df /= abs(a["metrics"]["punch_force_max_N"])
    return (f"- {scene.label}, {scene.ranks} rank(s): single {med['double'] / med['single']:.2f}"
            f" times as fast (median walls), linear solve per iteration "
            f"{split('single'):.1f} against {split('double'):.1f} ms; "
            f"{'the same' if same else 'different'} Newton iterations, punch force {df:.1e} "
            "apart (relative).")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="without the largest sandwich")
    args = parser.parse_args()
    scenes = [s for s in SCENES if not (args.quick and "36 x 36" in s.label)]
    lines = [
        "## MUMPS's LU in single precision, refined in double (issue 15)", "",
        f"Written by `python benchmarks/lu_precision.py` on {machine()}: each scene with "
        "`--set newton.lu_precision=double` and `=single`, alternated, "
        f"{args.repeats} runs each (the 36 x 36 x 8 sandwich one); nothing else running. "
        "Wall: the summary's wall_s less its JIT compilation [s]. Per iteration: rank "
        "means [ms]. Refinement: refinement iterations per linear solve (Richardson; FGMRES "
        "where the LU is compressed too) / solves that fell back to the exact (double) "
        "LU.", "",
        "| scene | unknowns | ranks | LU | wall [s] (each run) | Newton iterations | "
        "steps (rejected) | per iteration: kernel / assembly / linear solve [ms] | "
        "refinement | punch force max [N] | crushed volume [mm^3] |",
        "|---|---:|---:|---|---|---:|---|---|---|---:|---:|",
    ]
    verdicts = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, scene in enumerate(scenes):
            runs = alternate(scene.case, "newton.lu_precision", CHOICES, Path(tmp) / str(i),
                             scene.repeats or args.repeats, sets=scene.sets,
                             ranks=scene.ranks)
            lines += [_row(scene, c, runs[c]) for c in CHOICES]
            verdicts.append(_verdict(scene, runs))
    update_section("lu_precision", "\n".join(lines + [""] + verdicts))


if __name__ == "__main__":
    main()
