"""Command line: ``forming run CASE --out DIR --set key=value [-petsc_option value ...]``."""

from __future__ import annotations

import argparse
import sys

from forming.case import add_run_arguments, execute


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``forming`` command."""
    parser = argparse.ArgumentParser(prog="forming", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a case script from cases/")
    run.add_argument("case", help="case name, e.g. core_compression")
    add_run_arguments(run)
    args, extra = parser.parse_known_args(argv if argv is not None else sys.argv[1:])
    if args.command == "run":
        raise SystemExit(execute(args.case, args, extra))


if __name__ == "__main__":
    main()
