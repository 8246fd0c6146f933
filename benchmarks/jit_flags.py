"""What the C compiler flags of the solve forms cost to compile and buy in assembly.

The residual and Jacobian forms are compiled by FFCx with the flags of
``forming.compat.SOLVE_CFLAGS`` (``FORMING_SOLVE_CFLAGS`` overrides them). Each row runs a
case in a fresh process with the given flags, first on an empty FFCx cache (a fresh
``XDG_CACHE_HOME``: every form is compiled, as on a new machine or a cold CI runner),
then again on the cache that run filled; the flag sets alternate so that a drift of the
machine falls on all. A first, untimed run of each case compiles the numba kernels it
reaches, which would otherwise fall on the first cold row. It reports the set-up time
(``timing.jit_s``: the forms' compile, mesh and model), the assembly time per Newton
iteration, the Newton iterations and the case's force, whose bits show whether the flags
changed the arithmetic.

Run: ``python benchmarks/jit_flags.py [--write]`` (alone on the machine; about 20 minutes).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _report import machine, run_case_process, update_section

CASES = {  # label: (case, --set settings, the force metric)
    "hemisphere (P1 core)": ("hemisphere", (), "punch_force_max_N"),
    "meso_compression (Q2 walls), 1 x 1 cells": (
        "meso_compression", ("cells=1,1", "strain=0.02"), "peak_stress_MPa"),
}
FLAGS = ("-O3 -march=native", "-O3 -march=native -g0", "-O2 -march=native -g0")


def run(case: str, sets: tuple[str, ...], flags: str, cache: Path, out: Path) -> dict:
    """One run with ``flags`` and the FFCx cache in ``cache``; its summary."""
    env = {"FORMING_SOLVE_CFLAGS": flags, "XDG_CACHE_HOME": str(cache)}
    return run_case_process(case, out, sets=sets, env=env)


def main() -> None:
    """Run every case with every flag set, cold and then warm; print (and write) a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flags", nargs="+", default=list(FLAGS))
    parser.add_argument("--write", action="store_true",
                        help="write the table into docs/performance.md")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for label, (case, sets, metric) in CASES.items():
            # a first run, not timed, compiles the numba kernels the case reaches (their
            # cache is not the FFCx one), so that no cold row pays for them
            run(case, sets, args.flags[0], root / f"{case}-numba", root / f"{case}-numba-out")
            results: dict[tuple[str, str], dict] = {}
            for state in ("cold", "warm"):
                for k, flags in enumerate(args.flags):
                    cache = root / f"{case}-{k}"
                    results[flags, state] = run(case, sets, flags, cache,
                                                root / f"{case}-{k}-{state}")
            for flags in args.flags:
                for state in ("cold", "warm"):
                    s = results[flags, state]
                    t = s["timing"]
                    rows.append(
                        f"| {label} | `{flags}` | {state} | {t['jit_s']:.1f} | "
                        f"{t['per_iteration_ms']['assembly']:.1f} | "
                        f"{t['newton_iterations']} | {t['wall_s']:.1f} | "
                        f"{s['metrics'][metric]!r} |")
    body = (
        "## Compiling the solve forms: flags against time\n\n"
        f"Written by `python benchmarks/jit_flags.py --write`; {machine()}; the runs one "
        "after the other, nothing else running. Cold: an empty FFCx cache (every form "
        "compiled); warm: the cache that run filled. Set-up: `timing.jit_s` (the forms' "
        "compile, the mesh and the model); assembly: per Newton iteration "
        "(`timing.per_iteration_ms`); force: the case's own metric, to every digit "
        "(`punch_force_max_N`, `peak_stress_MPa`).\n\n"
        "| case | flags | cache | set-up [s] | assembly per iteration [ms] | Newton "
        "iterations | wall [s] | force |\n|---|---|---|---:|---:|---:|---:|---|\n"
        + "\n".join(rows) + "\n")
    print(body)
    if args.write:
        update_section("jit_flags", body)


if __name__ == "__main__":
    main()
