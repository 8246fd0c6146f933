"""The ``forming`` command: run a case, compare its solvers, list the cases.

forming list                               the cases, one line each
forming run CASE [--out DIR] [--set KEY=VALUE ...] [-forming_<petsc_option> VALUE]
                 [--checkpoint-every N]
forming run CASE --restart DIR [--checkpoint-every N]   continue from DIR's checkpoint
forming run CASE --help                    every parameter of CASE
forming compare CASE [--out DIR] [--set KEY=VALUE ...] [--reuse]
forming drape CASE [--tool NAME] [--out DIR] [--set KEY=VALUE ...] [--spacing D] [--angle DEG]
forming study CASE --vary KEY=V1,V2,... [--vary ...] [--metric NAME ...] [--set KEY=VALUE ...]
                   [--reference finest|extrapolated|VALUE] [--jobs N] [--ranks R] [--drape]
                   --out DIR
forming warmup [--part materials|solvers|contact]   compile the numba kernels once (cold cache)
forming --version
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from forming.case import REPO, add_restart_arguments, add_run_arguments, execute

log = logging.getLogger("forming")

DESCRIPTION = """\
Process simulation of press-formed sandwich panels (fabric skins on a crushable
honeycomb core between rigid tools): implicit Newton or explicit dynamics on DOLFINx.

commands:
  list       the cases, one line each
  run        run a case: forming run CASE --set KEY=VALUE (forming run CASE --help)
  compare    run a case with both solvers and compare them
  drape      kinematic drape (pin-jointed net) onto a tool of a case: shear-angle map
  study      run a case over combinations of parameters: table, convergence, cost
  warmup     compile the numba kernels once, before parallel runs on a cold cache

exit codes: 0 completed, 1 failed solve, 2 bad input, 3 file or folder error,
4 internal error, 130 interrupted (SIGINT), 143 stopped (SIGTERM).
"""


def _version() -> str:
    from forming import __version__
    from forming.provenance import git_commit

    git = git_commit()
    where = "" if git["commit"] is None else (
        f" (git {git['commit'][:12]}{', modified' if git['dirty'] else ''})")
    return f"forming {__version__}{where}"


def _list() -> int:
    from forming.casedoc import case_list

    cases = case_list(REPO / "cases")
    width = max(len(n) for n, _ in cases)
    for name, line in cases:
        print(f"{name:<{width}}  {line}")
    return 0


def _case_help(command: str, name: str) -> int:
    from forming.case import find_case, load_case
    from forming.casedoc import case_help
    from forming.errors import InputError

    try:
        find_case(name)
        module = load_case(name)
    except InputError as exc:
        print(f"forming: {exc}", file=sys.stderr)
        return 2
    restart = " [--checkpoint-every N] [--restart DIR]" if command == "run" else ""
    print(f"usage: forming {command} {name} [--out DIR] [--set KEY=VALUE ...] [--quiet]"
          f"{restart}\n")
    print(case_help(name, module.__doc__ or "", module.Params))
    return 0


def _compare(args: argparse.Namespace, extra: list[str]) -> int:
    from mpi4py import MPI

    from forming.case import apply_petsc_args, apply_picture_choice, guarded
    from forming.compare import compare
    from forming.log import setup

    setup(quiet=args.quiet)
    apply_picture_choice(args)
    comm = MPI.COMM_WORLD
    out = args.out or Path("results") / f"{args.case}_compare"
    def run() -> dict:
        apply_petsc_args(extra)
        return compare(args.case, out, args.assignments, reuse=args.reuse)

    r, code = guarded(comm, run)
    if code is not None:
        return code
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


def _drape(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from forming.case import guarded
    from forming.drape_case import run_drape
    from forming.log import setup

    setup(quiet=args.quiet)
    comm = MPI.COMM_WORLD
    out = args.out or Path("results") / f"{args.case}_drape"
    r, code = guarded(comm, lambda: run_drape(
        args.case, args.assignments, out, args.tool, args.spacing, args.angle, args.size,
        _point("--start", args.start), comm))
    if code is not None:
        return code
    if comm.rank == 0:
        s = r["settings"]
        print(f"{args.case}: drape onto {r['tool']}, d = {s['spacing']:.4g} mm, "
              f"{r['nodes_placed']} of {r['nodes_total']} nodes placed")
        for key in ("shear_min_deg", "shear_max_deg", "area_fraction_beyond_limits", "wall_s"):
            print(f"  {key} = {r[key]}")
        print(f"outputs in {Path(out).resolve()}")
    return 0


def _calibrate(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from forming.calibrate import calibrate
    from forming.case import guarded
    from forming.log import setup

    setup(quiet=args.quiet)
    comm = MPI.COMM_WORLD
    out = args.out or Path("results") / f"{args.case}_calibration"
    r, code = guarded(comm, lambda: calibrate(args.case, out, args.assignments,
                                              not args.no_moduli))
    if code is not None:
        return code
    if comm.rank == 0:
        print(f"{args.case}: C365 curve {r['curve']} ({r['points']} points to strain "
              f"{r['strain_end']:.4g}; modulus {r['modulus_MPa']:.4g} MPa)")
        if r["cut"]:
            print(f"  ends early: {r['cut']}")
        print(f"  macro check: {r['check_status']}, relative RMS error {r['check_rmse_rel']}")
        for key in ("shear_modulus_xz_MPa", "shear_modulus_yz_MPa", "inplane_modulus_x_MPa",
                    "inplane_modulus_y_MPa", "inplane_poisson_x", "inplane_poisson_y"):
            if key in r:
                print(f"  {key} = {r[key]}")
        print(f"  use it: {r['use']}")
        print(f"  the macro core's moduli: honeycomb_core(curve=..., **{r['core_overrides']})")
        print(f"outputs in {Path(out).resolve()}")
    return 0 if r["check_status"] == "completed" else 1


def _study(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from forming.case import guarded
    from forming.log import setup
    from forming.study import parse_study, run_study
    from forming.study_report import report

    setup(quiet=args.quiet)
    if MPI.COMM_WORLD.size > 1:
        print("forming: run forming study without mpirun (--ranks R runs each case on R "
              "ranks)", file=sys.stderr)
        return 2

    def run() -> dict:
        study = parse_study(args.case, args.vary, args.out, args.assignments, args.metric,
                            args.reference, args.jobs, args.ranks, args.drape)
        return report(study, run_study(study))

    r, code = guarded(MPI.COMM_WORLD, run)
    if code is not None:
        return code
    print(f"{args.case}: {r['completed']} of {r['runs']} runs completed "
          f"({r['reused']} reused)")
    for metric, found in r["convergence"].items():
        for c in found:
            print(f"  {metric} over {c['key']}: order {c['order']:.2f}, extrapolated "
                  f"{c['extrapolated']:.6g}, GCI {100 * c['gci']:.2g}%")
    print(f"report in {Path(r['md']).resolve()}")
    return 0 if r["completed"] == r["runs"] else 1


def _optimise_blank(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from forming.case import guarded
    from forming.demonstrator.develop import optimise_blank
    from forming.log import setup

    setup(quiet=args.quiet)
    comm = MPI.COMM_WORLD
    out = args.out or Path("results") / f"{args.case}_blank"
    r, code = guarded(comm, lambda: optimise_blank(args.case, out, args.assignments,
                                                   args.tolerance, args.max_runs,
                                                   args.margin))
    if code is not None:
        return code
    if comm.rank == 0:
        devs = ", ".join(f"{d:.3g}" for d in r["trim_deviation_max_mm"])
        state = "converged" if r["converged"] else "not converged"
        print(f"{args.case}: blank {state} in {r['iterations']} runs (formed edge to trim "
              f"line, largest: {devs} mm; tolerance {args.tolerance:g} mm)")
        print(f"outputs in {Path(out).resolve()}")
    return 0 if r["converged"] else 1


def _add_study_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("case", help="case name (forming list)")
    parser.add_argument("--vary", action="append", required=True, metavar="KEY=V1,V2,...",
                        help="a varied parameter and its levels (repeatable: every "
                             "combination runs); levels holding commas are separated by "
                             "':' (cells=8,8,2:12,12,3)")
    parser.add_argument("--metric", action="append", default=[], metavar="NAME",
                        help="a summary.json metric to judge and plot (repeatable; "
                             "default: every metric)")
    parser.add_argument("--set", dest="assignments", action="append", default=[],
                        metavar="KEY=VALUE", help="a parameter every run shares")
    parser.add_argument("--reference", default="extrapolated",
                        help="errors against: 'extrapolated' (Richardson, else the finest "
                             "run), 'finest', or a number")
    parser.add_argument("--drape", action="store_true",
                        help="each run is the kinematic drape onto the case's tool "
                             "(forming drape), varied through drape.spacing=... etc.")
    parser.add_argument("--jobs", type=int, default=1, help="runs at a time")
    parser.add_argument("--ranks", type=int, default=1, help="MPI ranks per run")
    parser.add_argument("--out", type=Path, required=True,
                        help="the study's folder (runs already in it are reused)")
    parser.add_argument("--quiet", action="store_true", help="warnings and errors only")


def _point(name: str, text: str | None) -> tuple[float, float, float] | None:
    """``X,Y,Z`` as three floats (None stays None)."""
    from forming.errors import InputError

    if text is None:
        return None
    try:
        p = tuple(float(v) for v in text.split(","))
    except ValueError:
        p = ()
    if len(p) != 3:
        raise InputError(name, f"expected X,Y,Z in mm, got {text!r}")
    return p


def _add_drape_arguments(parser: argparse.ArgumentParser) -> None:
    from forming.drape_case import DEFAULT_ANGLE

    parser.add_argument("case", help="case name (forming list)")
    parser.add_argument("--tool", default=None,
                        help="the tool to drape onto (default: the case's first tool)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default results/<case>_drape); a folder holding "
                             "an earlier drape is cleared of its files first")
    parser.add_argument("--set", dest="assignments", action="append", default=[],
                        metavar="KEY=VALUE", help="set a case parameter (repeatable); "
                        "drape.spacing=, drape.angle=, drape.size=, drape.tool= set the "
                        "drape's own options")
    parser.add_argument("--spacing", type=float, default=None, metavar="D",
                        help="net spacing, the edge of a cell [mm] (default: the blank's "
                             "in-plane element size)")
    parser.add_argument("--angle", type=float, default=None, metavar="DEG",
                        help="plan-view angle of the first fibre family from x [deg]; the "
                             f"second starts at DEG + 90 (default {DEFAULT_ANGLE:g}: the skins' "
                             "+/-45 deg)")
    parser.add_argument("--size", type=float, default=None, metavar="MM",
                        help="side of the square net [mm] (default: the blank's larger side)")
    parser.add_argument("--start", default=None, metavar="X,Y,Z",
                        help="where the net's origin node is pinned, a point on the tool at "
                             "the end of the stroke [mm] (default: half a cell from the tool's "
                             "point closest to the blank's centre, which is then the origin "
                             "cell's centre); write --start=X,Y,Z when X is negative")
    parser.add_argument("--quiet", action="store_true", help="warnings and errors only")


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``forming`` command."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # forming run CASE --help: the case's own parameters, not the generic options
    if (len(argv) >= 2 and argv[0] in ("run", "compare") and not argv[1].startswith("-")
            and {"-h", "--help"} & set(argv[2:])):
        raise SystemExit(_case_help(argv[0], argv[1]))
    parser = argparse.ArgumentParser(prog="forming", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=_version())
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser("list", help="the cases, one line each")
    run = sub.add_parser("run", help="run a case (forming run CASE --help: its parameters)")
    run.add_argument("case", help="case name (forming list)")
    add_run_arguments(run)
    add_restart_arguments(run)
    cmp_ = sub.add_parser("compare", help="run a case with both solvers and compare them")
    cmp_.add_argument("case", help="case name (forming list)")
    add_run_arguments(cmp_)
    cmp_.add_argument("--reuse", action="store_true",
                      help="compare the runs already in --out again (nothing is run)")
    drape = sub.add_parser("drape", help="kinematic drape onto a tool of a case "
                                         "(shear-angle map, drape.json, drape.vtu)")
    _add_drape_arguments(drape)
    _add_study_arguments(sub.add_parser(
        "study", help="run a case over combinations of parameters (study.csv, study.md)"))
    cal = sub.add_parser("calibrate", help="the macro core's C365 curve from a meso case "
                                           "(c365_meso.csv, checked by core_compression)")
    cal.add_argument("case", help="meso case (meso_compression)")
    cal.add_argument("--out", type=Path, default=None,
                     help="output folder (default results/<case>_calibration)")
    cal.add_argument("--set", dest="assignments", action="append", default=[],
                     metavar="KEY=VALUE", help="set a parameter of the meso case (repeatable)")
    cal.add_argument("--no-moduli", action="store_true",
                     help="skip the transverse shear and in-plane tension runs (the "
                          "shear and in-plane moduli)")
    cal.add_argument("--quiet", action="store_true", help="warnings and errors only")
    opt = sub.add_parser("optimise-blank", help="net-shape blank: form, map the trim line "
                                                "back, re-mesh, until the edge meets it")
    opt.add_argument("case", help="a case with a blank outline and a trim line (demonstrator)")
    opt.add_argument("--out", type=Path, default=None,
                     help="output folder (default results/<case>_blank); resumed if it holds runs")
    opt.add_argument("--set", dest="assignments", action="append", default=[],
                     metavar="KEY=VALUE", help="set a parameter of the case (repeatable)")
    opt.add_argument("--tolerance", type=float, default=2.0,
                     help="largest distance of the formed edge to the trim line [mm]")
    opt.add_argument("--max-runs", type=int, default=4, help="simulations at most")
    opt.add_argument("--margin", type=float, default=0.0,
                     help="added outside the mapped trim line [mm] (0: net shape)")
    opt.add_argument("--quiet", action="store_true", help="warnings and errors only")
    warm = sub.add_parser("warmup", help="compile the numba kernels into NUMBA_CACHE_DIR once "
                                         "(before parallel runs or tests on a cold cache)")
    warm.add_argument("--part", choices=("materials", "solvers", "contact"), default=None,
                      help="one part only (processes can share the work); default all")
    args, extra = parser.parse_known_args(argv)
    if args.command == "warmup":
        if extra:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        from forming import log as logs
        from forming import warmup

        logs.setup()
        raise SystemExit(warmup.main(args.part))
    if args.command == "study":
        if extra:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        raise SystemExit(_study(args))
    if args.command == "calibrate":
        if extra:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        raise SystemExit(_calibrate(args))
    if args.command == "drape":
        if extra:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        raise SystemExit(_drape(args))
    if args.command == "optimise-blank":
        if extra:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        raise SystemExit(_optimise_blank(args))
    if args.command == "list":
        raise SystemExit(_list())
    if args.command == "run":
        raise SystemExit(execute(args.case, args, extra))
    raise SystemExit(_compare(args, extra))


if __name__ == "__main__":
    main()
