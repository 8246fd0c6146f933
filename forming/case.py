"""Case plumbing: typed parameters from ``--set key=value``, and the script entry point.

A case script in ``cases/`` defines a frozen dataclass ``Params`` and a function
``build(params) -> Job``; ``main()`` at its bottom makes it runnable as a script, and
``forming run NAME`` finds it by name.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import logging
import math
import os
import sys
import time
import types
import typing
from pathlib import Path

from forming.errors import EXIT_CODES, InputError

log = logging.getLogger(__name__)

REPO = Path(__file__).resolve().parent.parent


def _convert(name: str, text: str, hint) -> object:
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        choices = typing.get_args(hint)
        if text not in choices:
            raise InputError(name, f"must be one of {list(choices)}, got {text!r}")
        return text
    if origin in (types.UnionType, typing.Union):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if text.lower() in ("none", "null") and len(args) < len(typing.get_args(hint)):
            return None
        return _convert(name, text, args[0])
    if origin is tuple:
        inner = typing.get_args(hint)[0]
        return tuple(_convert(name, t.strip(), inner) for t in text.split(",") if t.strip())
    if hint is bool:
        low = text.lower()
        if low in ("1", "true", "yes", "on"):
            return True
        if low in ("0", "false", "no", "off"):
            return False
        raise InputError(name, f"must be true or false, got {text!r}")
    if hint in (int, float):
        try:
            value = hint(text)
        except ValueError as exc:
            raise InputError(name, f"must be {hint.__name__}, got {text!r}") from exc
        if hint is float and not math.isfinite(value):
            raise InputError(name, f"must be a finite number, got {text!r}")
        return value
    return text


def require(params, positive: tuple[str, ...] = (), nonnegative: tuple[str, ...] = (),
            fraction: tuple[str, ...] = ()) -> None:
    """Refuse parameter values that cannot mean anything, naming the ``--set`` key.

    Args:
        params: A case's parameters.
        positive: Names that must be > 0 (sizes, strokes, strains).
        nonnegative: Names that must be >= 0 (clearances, friction).
        fraction: Names that must lie strictly between 0 and 1 (a nominal strain).

    An optional parameter left at None passes.

    Raises:
        InputError: The first offending parameter.
    """
    for name in positive:
        if getattr(params, name) is not None and not getattr(params, name) > 0:
            raise InputError(f"--set {name}", f"must be > 0, got {getattr(params, name)}")
    for name in nonnegative:
        if not getattr(params, name) >= 0:
            raise InputError(f"--set {name}", f"must be >= 0, got {getattr(params, name)}")
    for name in fraction:
        if not 0 < getattr(params, name) < 1:
            raise InputError(f"--set {name}",
                             f"must lie between 0 and 1, got {getattr(params, name)}")


def parse_params(params_cls: type, assignments: list[str], prefix: str = "") -> object:
    """Build ``params_cls`` from its defaults and ``key=value`` strings.

    ``prefix`` is prepended to the key in error messages (``explicit.``).

    Raises:
        InputError: Malformed assignment, unknown key (listing the known ones) or a value
            of the wrong type.
    """
    hints = typing.get_type_hints(params_cls)
    known = {f.name for f in dataclasses.fields(params_cls)}
    values: dict[str, object] = {}
    for item in assignments:
        if "=" not in item:
            raise InputError("--set", f"expected key=value, got {item!r}")
        key, text = item.split("=", 1)
        key = key.strip()
        if key not in known:
            raise InputError(f"--set {prefix}{key}",
                             f"unknown parameter; known: {sorted(prefix + k for k in known)}")
        values[key] = _convert(f"--set {prefix}{key}", text.strip(), hints[key])
    return params_cls(**values)


def find_case(name: str) -> Path:
    """Path of ``cases/<name>.py`` (repository checkout or current directory)."""
    for root in (Path.cwd(), REPO):
        p = root / "cases" / f"{name}.py"
        if p.is_file():
            return p
    known = sorted(p.stem for p in (REPO / "cases").glob("*.py") if not p.stem.startswith("_"))
    raise InputError("case", f"unknown case {name!r}; known: {known}")


def load_case(name: str) -> types.ModuleType:
    """Import a case script as a module."""
    path = find_case(name)
    spec = importlib.util.spec_from_file_location(f"forming_case_{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve annotations through it
    spec.loader.exec_module(module)
    for attr in ("Params", "build"):
        if not hasattr(module, attr):
            raise InputError("case", f"{path} defines no {attr}")
    return module


@dataclasses.dataclass(frozen=True)
class SolverChoice:
    """Solver settings every case accepts (``--set solver=explicit``).

    Attributes:
        solver: ``"implicit"`` or ``"explicit"``; None: the case's own choice.
    """

    solver: typing.Literal["implicit", "explicit"] | None = None


SOLVER_PREFIXES = ("explicit.", "newton.")


def split_solver_settings(assignments: list[str]) -> tuple[list[str], dict[str, list[str]],
                                                           list[str]]:
    """Split ``--set`` items into the solver choice, solver settings and the rest.

    Returns:
        (``solver=...`` items, ``{"explicit.": [...], "newton.": [...]}`` with the prefix
        removed, the case's own items).
    """
    choice, rest = [], []
    settings: dict[str, list[str]] = {p: [] for p in SOLVER_PREFIXES}
    for item in assignments:
        key = item.split("=", 1)[0].strip()
        prefix = next((p for p in SOLVER_PREFIXES if key.startswith(p)), None)
        if key == "solver":
            choice.append(item)
        elif prefix is not None:
            settings[prefix].append(item.strip()[len(prefix):])
        else:
            rest.append(item)
    return choice, settings, rest


def _with_settings(options, items: list[str], prefix: str):
    """``options`` (a frozen dataclass) with the ``key=value`` items replacing fields."""
    if not items:
        return options
    given = parse_params(type(options), items, prefix)
    keys = {item.split("=", 1)[0].strip() for item in items}
    return dataclasses.replace(options, **{k: getattr(given, k) for k in keys})


def apply_solver_settings(job, choice: list[str], settings: dict[str, list[str]]):
    """The job with the solver, explicit and Newton settings given on the command line."""
    picked = parse_params(SolverChoice, choice)
    if picked.solver is not None:
        job = dataclasses.replace(job, solver=picked.solver)
    return dataclasses.replace(
        job, explicit=_with_settings(job.explicit, settings["explicit."], "explicit."),
        newton=_with_settings(job.newton, settings["newton."], "newton."))


def resolve_partition(params, solver: str | None):
    """``params`` with a ``partition`` of ``"auto"`` made concrete for the solver asked for.

    Angular wedges (:mod:`forming.partition`) for an explicit run, the graph partition
    otherwise. Measured on the 20 x 20 x 4 hemisphere with holder on 2 ranks
    (docs/performance.md): the explicit increments run 1.1-1.2 times faster in wedges (the
    crushing region shared, element-loop imbalance 1.16 -> 1.00), while the implicit
    run's MUMPS factorisation is 1.3-1.5 times slower on them. Parameters without the
    field, or with another value, are returned as given.
    """
    if getattr(params, "partition", None) != "auto":
        return params
    return dataclasses.replace(params, partition="wedge" if solver == "explicit" else "graph")


def prepare_case(name: str, assignments: list[str], build=None, params_cls=None):
    """The job of case ``name`` with ``--set`` assignments, and its parameters as recorded.

    Besides the case's parameters every case accepts ``solver=implicit|explicit``,
    ``explicit.<setting>=value`` (:class:`~forming.solver.options.ExplicitOptions`) and
    ``newton.<setting>=value`` (:class:`~forming.solver.options.NewtonOptions`).
    """
    if build is None:
        module = load_case(name)
        build, params_cls = module.build, module.Params
    choice, settings, rest = split_solver_settings(assignments)
    params = resolve_partition(parse_params(params_cls, rest),
                               parse_params(SolverChoice, choice).solver)
    try:
        job = build(params)
    except InputError as exc:
        if exc.field.startswith("--set"):
            raise
        given = " ".join(f"--set {a}" for a in rest) or "its defaults"
        raise InputError(exc.field, f"{str(exc).split(': ', 1)[-1]} (building case {name} "
                         f"with {given})") from exc
    job = apply_solver_settings(job, choice, settings)
    return job, dataclasses.asdict(params)


def _settings(assignments: list[str], params_cls: type) -> dict[str, object]:
    """Every setting that ``--set`` items give a job: the case's, the solver's."""
    from forming.solver.options import ExplicitOptions, NewtonOptions

    choice, settings, rest = split_solver_settings(assignments)
    out = dict(dataclasses.asdict(parse_params(params_cls, rest)))
    out["solver"] = parse_params(SolverChoice, choice).solver
    for prefix, cls in (("explicit.", ExplicitOptions), ("newton.", NewtonOptions)):
        given = dataclasses.asdict(parse_params(cls, settings[prefix], prefix))
        out |= {f"{prefix}{k}": v for k, v in given.items()}
    return out


def restart_settings(name: str, folder: Path, given: list[str], params_cls: type
                     ) -> tuple[list[str], dict]:
    """The ``--set`` items of the run whose checkpoint is in ``folder``, and its metadata.

    A restart rebuilds the job from the items the run was started with; items given
    again must not change any setting.

    Raises:
        InputError: ``folder`` is missing or holds no readable checkpoint, the checkpoint
            is of another case, or ``given`` changes a setting.
    """
    from forming import restart

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("--restart", f"{folder} is not a folder"
                         + ("" if folder.exists() else " (it does not exist)"))
    meta = restart.read_meta(restart.checkpoint_path(folder))
    if meta.get("case") != name:
        raise InputError("--restart", f"{folder} holds a run of case {meta.get('case')!r}, not "
                         f"{name!r}: forming run {meta.get('case')} --restart {folder}")
    stored = meta.get("assignments")
    if stored is None:
        raise InputError("--restart", f"{restart.checkpoint_path(folder)} was written by a "
                         "simulation built in Python, with no --set record: restart it with "
                         "Simulation(job, out, restart=True)")
    if given:
        before, after = _settings(stored, params_cls), _settings(stored + given, params_cls)
        changed = sorted(k for k in after if after[k] != before[k])
        if changed:
            was = ", ".join(f"{k}={before[k]}" for k in changed)
            raise InputError("--set", f"a restart continues the run in {folder}, computed with "
                             f"{was}: it cannot change {changed} (start a new run instead)")
    return list(stored), meta


def run_case(name: str, out: Path, assignments: list[str], build=None, params_cls=None,
             checkpoint_every: int | None = None, restart: bool = False) -> dict:
    """Run case ``name`` with ``--set`` assignments; write the output contract into ``out``.

    See :func:`prepare_case` for the settings every case accepts.

    Args:
        name: The case.
        out: Output folder (with ``restart``: the folder of the run to continue).
        assignments: ``--set`` items.
        build: The case's ``build`` (None: load the case by name).
        params_cls: The case's ``Params``.
        checkpoint_every: Write a checkpoint every this many converged steps (None: the
            job's own setting; on restart, the interrupted run's).
        restart: Continue the run in ``out`` from its checkpoint, with the settings it
            was started with (:func:`restart_settings`).
    """
    from forming.run import simulate

    if build is None:
        module = load_case(name)
        build, params_cls = module.build, module.Params
    if restart:
        assignments, meta = restart_settings(name, Path(out), assignments, params_cls)
        if checkpoint_every is None:
            checkpoint_every = meta.get("checkpoint_every")
    job, params = prepare_case(name, assignments, build, params_cls)
    if checkpoint_every is not None:
        job = dataclasses.replace(job, checkpoint_every=checkpoint_every)  # validated
    return simulate(job, Path(out), name, params, list(assignments), restart)


def apply_petsc_args(extra: list[str]) -> None:
    """Pass ``-option value`` pairs left on the command line to PETSc.

    PETSc's options take one dash; a word with two dashes that the parser did not know is
    a mistyped option of ours (``--set-py``), refused before anything runs. ``-log_view``
    starts PETSc's event log, whose summary PETSc prints when the run ends.
    """
    for key in extra:
        if key.startswith("--"):
            raise InputError("command line", f"unknown option {key!r} (see --help; PETSc "
                             "options take one dash, as -forming_snes_rtol 1e-8)")
    from petsc4py import PETSc

    from forming import compat  # noqa: F401

    opts = PETSc.Options()
    i = 0
    while i < len(extra):
        key = extra[i]
        if not key.startswith("-"):
            raise InputError("command line", f"unexpected argument {key!r}")
        if i + 1 < len(extra) and not extra[i + 1].startswith("-"):
            opts[key.lstrip("-")] = extra[i + 1]
            i += 2
        else:
            opts[key.lstrip("-")] = None
            i += 1
    if any(k.lstrip("-").split(":")[0] == "log_view" for k in extra):
        # PETSc reads -log_view only when it starts logging, which petsc4py did before
        # these options existed: begin now, and PETSc prints its summary at the end
        PETSc.Log.begin()


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """``--out``, ``--set`` and ``--quiet`` options of a case run."""
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default results/<case>); a folder holding an "
                             "earlier run is cleared of its files first, a non-empty folder "
                             "without a run is refused")
    parser.add_argument("--set", dest="assignments", action="append", default=[],
                        metavar="KEY=VALUE", help="set a case parameter (repeatable)")
    parser.add_argument("--quiet", action="store_true",
                        help="warnings and errors only, no progress line")
    parser.add_argument("--no-pictures", action="store_true",
                        help="leave out the case's 3D views and sections (about a second "
                             "each; the plots are drawn): as FORMING_PICTURES=0")


def apply_picture_choice(args: argparse.Namespace) -> None:
    """``--no-pictures`` given: the runs of this process draw no pictures (every rank)."""
    from forming.output import PICTURES_ENV

    if getattr(args, "no_pictures", False):
        os.environ[PICTURES_ENV] = "0"


def add_restart_arguments(parser: argparse.ArgumentParser) -> None:
    """``--checkpoint-every`` and ``--restart`` options of a case run."""
    parser.add_argument("--checkpoint-every", type=int, default=None, metavar="N",
                        help="write a checkpoint (checkpoint.npz) every N converged steps "
                             "(0: none; default 10, or the case's own); "
                             "Ctrl-C and SIGTERM always leave one")
    parser.add_argument("--restart", type=Path, default=None, metavar="DIR",
                        help="continue the run in DIR from its checkpoint, on any number of "
                             "ranks, with the settings it was started with (--set may only "
                             "repeat them)")


def execute(name: str, args: argparse.Namespace, extra: list[str], build=None,
            params_cls=None) -> int:
    """Run a case from parsed arguments; report where the outputs are.

    An error on any rank ends every rank promptly (``MPI_Abort`` under ``mpirun``).

    Returns:
        The exit code (:data:`forming.errors.EXIT_CODES`).
    """
    from mpi4py import MPI

    from forming.log import setup

    setup(quiet=getattr(args, "quiet", False))
    apply_picture_choice(args)
    comm = MPI.COMM_WORLD
    restart = getattr(args, "restart", None)
    out = restart or args.out or Path("results") / name

    def run() -> dict:
        if restart is not None and args.out is not None and (
                Path(args.out).resolve() != Path(restart).resolve()):
            raise InputError("--out", "a restart continues in the folder of its run "
                             f"({restart}): leave out --out")
        apply_petsc_args(extra)
        return run_case(name, out, args.assignments, build, params_cls,
                        getattr(args, "checkpoint_every", None), restart is not None)

    summary, code = guarded(comm, run)
    if code is not None:
        return code
    if comm.rank == 0:
        _report(name, summary, Path(out))
    if summary["status"] == "interrupted":
        return EXIT_CODES[summary.get("signal", "SIGINT")]
    return EXIT_CODES["completed"] if summary["status"] == "completed" else EXIT_CODES["failed"]


def guarded(comm, fn):
    """Call ``fn()``; an error becomes its exit code (:func:`end_with_error`).

    Returns:
        ``(result, None)``, or ``(None, exit code)`` after an error.
    """
    try:
        return fn(), None
    except InputError as exc:
        return None, end_with_error(comm, "input", str(exc))
    except OSError as exc:
        return None, end_with_error(comm, "io", str(exc))
    except Exception as exc:  # noqa: BLE001  (reported, then every rank ends)
        log.exception("internal error")
        return None, end_with_error(comm, "internal", f"{type(exc).__name__}: {exc}")


def end_with_error(comm, kind: str, message: str, wait: float = 2.0) -> int:
    """Report an error and return its exit code; under MPI make sure every rank ends.

    An error found by every rank (a collective check) ends each rank normally. One
    raised on some ranks only would leave the others waiting in a collective: if not
    every rank reaches this point within ``wait`` seconds, ``MPI_Abort`` ends them all.
    """
    log.error("%s", message)
    for handler in logging.getLogger("forming").handlers:
        handler.flush()
    code = EXIT_CODES[kind]
    if comm.size > 1:
        request = comm.Ibarrier()
        end = time.monotonic() + wait
        while not request.Test():
            if time.monotonic() > end:
                comm.Abort(code)
            time.sleep(0.01)
    return code


def _report(name: str, summary: dict, out: Path) -> None:
    """The run's outcome, metrics, cost and output folder on standard output."""
    print(f"{name}: {summary['status']}"
          + (f" ({summary['reason']})" if summary["reason"] else ""))
    for k, v in summary["metrics"].items():
        print(f"  {k} = {v}")
    for w in summary.get("warnings", []):
        print(f"  warning: {w}")
    timing = summary["timing"]
    print(f"  wall {timing['wall_s']:.2f} s, {timing['steps']} steps, "
          f"{timing['work']} {timing['work_name']}")
    print(f"outputs in {out.resolve()}")


def main(build, params_cls, name: str) -> None:
    """Entry point at the bottom of a case script (``python cases/NAME.py --help``)."""
    from forming.casedoc import case_help

    module = sys.modules.get(build.__module__)
    parser = argparse.ArgumentParser(
        prog=f"{name}.py", formatter_class=argparse.RawDescriptionHelpFormatter,
        description=case_help(name, getattr(module, "__doc__", None) or "", params_cls))
    add_run_arguments(parser)
    add_restart_arguments(parser)
    args, extra = parser.parse_known_args()
    raise SystemExit(execute(name, args, extra, build, params_cls))
