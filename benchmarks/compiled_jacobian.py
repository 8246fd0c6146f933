"""The core's Jacobian from its UFL form against compiled element matrices, in a run.

`hemisphere` on the 20,20,4 quarter mesh, without and with blank holder, serial, with
``newton.jacobian=forms`` (DOLFINx assembles the body's tangent from its form) and
``newton.jacobian=compiled`` (:mod:`forming.solver.tangents`), alternated ``--repeats``
times so that the machine's drift falls on both alike. For each: wall time, Newton
iterations, the per-iteration split (kernel, assembly, linear solve), and the answer
(punch force, crushed volume), which must not move beyond round-off. Writes
docs/performance.md's ``compiled_jacobian`` section.

Run: ``python benchmarks/compiled_jacobian.py`` (about 8 minutes on 2 cores, nothing
else running).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from _report import alternate, machine, update_section

CHOICES = ("forms", "compiled")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", default="20,20,4")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    runs: dict[tuple[bool, str], list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for holder in (False, True):
            got = alternate("hemisphere", "newton.jacobian", CHOICES, Path(tmp) / str(holder),
                            args.repeats, sets=(f"cells={args.cells}",
                                                f"blank_holder={holder}"))
            runs |= {(holder, c): rs for c, rs in got.items()}
    lines = [
        "## The core's Jacobian: forms against compiled element matrices (issue 15)", "",
        f"Written by `python benchmarks/compiled_jacobian.py` on {machine()}: `hemisphere "
        f"--set cells={args.cells} --set blank_holder=H --set newton.jacobian=J`, serial, "
        f"the two choices alternated, {args.repeats} runs each; nothing else running. "
        "Wall: the summary's wall_s (JIT caches warm). Per iteration: rank means [ms].", "",
        "| blank holder | Jacobian | wall [s] (each run) | Newton iterations | steps (rejected)"
        " | per iteration: kernel / assembly / linear solve [ms] | punch force max [N] | "
        "crushed volume [mm^3] |",
        "|---|---|---|---:|---|---|---:|---:|",
    ]
    verdicts = []
    for holder in (False, True):
        walls = {}
        for choice in CHOICES:
            rs = runs[holder, choice]
            t, m = rs[-1]["timing"], rs[-1]["metrics"]
            split = t["per_iteration_ms"]
            walls[choice] = [r["timing"]["wall_s"] for r in rs]
            lines.append(
                f"| {holder} | {choice} | {', '.join(f'{w:.1f}' for w in walls[choice])} | "
                f"{t['newton_iterations']} | {t['steps']} ({t['rejected_steps']}) | "
                f"{split['kernel']:.1f} / {split['assembly']:.1f} / "
                f"{split['linear_solve']:.1f} | {m['punch_force_max_N']:.10g} | "
                f"{m['crushed_volume_mm3']:.8g} |")
        a, b = (runs[holder, c][-1] for c in CHOICES)
        df = abs(a["metrics"]["punch_force_max_N"] - b["metrics"]["punch_force_max_N"])
        ratio = statistics.median(walls["forms"]) / statistics.median(walls["compiled"])
        same = a["timing"]["newton_iterations"] == b["timing"]["newton_iterations"]
        verdicts.append(
            f"- blank holder {holder}: compiled {ratio:.2f} times as fast (median walls); "
            f"{'the same' if same else 'different'} Newton iterations; punch force "
            f"{df / a['metrics']['punch_force_max_N']:.1e} apart (relative).")
    update_section("compiled_jacobian", "\n".join(lines + [""] + verdicts))


if __name__ == "__main__":
    main()
