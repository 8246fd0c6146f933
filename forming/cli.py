"""Command line.

``forming run CASE --out DIR --set key=value [-petsc_option value ...]`` runs a case;
``forming compare CASE --out DIR --set key=value`` runs it with the implicit and the
explicit solver and writes a comparison report (:mod:`forming.compare`).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from forming.case import add_run_arguments, execute

log = logging.getLogger("forming")


def _compare(args: argparse.Namespace, extra: list[str]) -> int:
    from mpi4py import MPI

    from forming.case import apply_petsc_args, end_with_error
    from forming.compare import compare
    from forming.errors import InputError
    from forming.log import setup

    setup()
    comm = MPI.COMM_WORLD
    out = args.out or Path("results") / f"{args.case}_compare"
    try:
        apply_petsc_args(extra)
        r = compare(args.case, out, args.assignments, reuse=args.reuse)
    except InputError as exc:
        return end_with_error(comm, "input", str(exc))
    except OSError as exc:
        return end_with_error(comm, "io", str(exc))
    if MPI.COMM_WORLD.rank == 0:
        print(f"{args.case}: implicit {r['status_implicit']}, explicit {r['status_explicit']}")
        for key in ("force_rms_diff_rel", "peak_force_diff_rel", "shape_rms_diff_rel_thickness",
                    "energy_balance_error_rel", "kinetic_to_internal_max",
                    "explicit_quasi_static", "wall_s_implicit", "wall_s_explicit",
                    "meets_targets"):
            print(f"  {key} = {r[key]}")
        print(f"report in {(Path(out) / 'report.md').resolve()}")
    both = r["status_implicit"] == r["status_explicit"] == "completed"
    return 0 if both else 1


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``forming`` command."""
    parser = argparse.ArgumentParser(prog="forming", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a case script from cases/")
    run.add_argument("case", help="case name, e.g. core_compression")
    add_run_arguments(run)
    cmp_ = sub.add_parser("compare", help="run a case with both solvers and compare them")
    cmp_.add_argument("case", help="case name, e.g. core_crushing")
    add_run_arguments(cmp_)
    cmp_.add_argument("--reuse", action="store_true",
                      help="compare the runs already in --out again (nothing is run)")
    args, extra = parser.parse_known_args(argv if argv is not None else sys.argv[1:])
    if args.command == "run":
        raise SystemExit(execute(args.case, args, extra))
    raise SystemExit(_compare(args, extra))


if __name__ == "__main__":
    main()
