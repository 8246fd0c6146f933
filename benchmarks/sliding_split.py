"""Where a finite-sliding interface's time goes: timers around its parts, one run.

Runs a case in this process with wall-clock timers wrapped around the parts of
:class:`~forming.contact.sliding.SlidingTerm` (its Jacobian and residual, the compiled
loops over the pairs, the pairing and the area transfer's walk) and prints each part's
total, call count and time per call. The case's own ``summary.json`` gives the whole
run's split (``timing.per_iteration_ms``, ``timing.sliding_s``,
``timing.sliding_imbalance``); this says what is inside ``sliding_s``. The timers add
about a microsecond per call.

Run: ``python benchmarks/sliding_split.py demonstrator --set element_size=60`` (about
2.5 minutes on one core; docs/performance.md, "The demonstrator: cost").
"""

from __future__ import annotations

import argparse
import collections
import runpy
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import forming.contact.sliding as sliding  # noqa: E402
import forming.contact.tributary as tributary  # noqa: E402

TOTAL: dict[str, float] = collections.defaultdict(float)
CALLS: collections.Counter = collections.Counter()


def _timed(name: str, fn):
    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            TOTAL[name] += time.perf_counter() - t0
            CALLS[name] += 1
    return wrapper


def _install() -> None:
    """Wrap the module functions sliding.py calls and the methods of its classes."""
    for name in ("jacobian_all", "residual_all", "pair_all", "search_all", "node_normals",
                 "distinct_facets", "jacobian_blocks", "add_blocks"):
        if hasattr(sliding, name):  # (an older revision has no add_blocks)
            setattr(sliding, name, _timed(name, getattr(sliding, name)))
    for cls, names in ((sliding.SlidingTerm, ("add_jacobian", "add_residual", "_pair")),
                       (tributary.AreaTransfer, ("follow", "repair"))):
        for name in names:
            setattr(cls, name, _timed(f"{cls.__name__}.{name}", getattr(cls, name)))


def main() -> None:
    """Run the case with the timers and print the split."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case", help="a case of cases/ with finite sliding")
    parser.add_argument("--set", dest="sets", action="append", default=[])
    args = parser.parse_args()
    script = REPO / "cases" / f"{args.case}.py"
    if not script.is_file():
        raise SystemExit(f"no case {args.case!r} ({script} is missing)")
    _install()
    with tempfile.TemporaryDirectory() as out:
        sys.argv = [str(script), "--out", out] + [a for s in args.sets for a in ("--set", s)]
        try:
            runpy.run_path(str(script), run_name="__main__")
        except SystemExit as stop:  # a case script ends with sys.exit(its status)
            if stop.code not in (0, None):
                raise
    print(f"{'part':32s} {'total [s]':>10s} {'calls':>8s} {'per call [ms]':>14s}")
    for name, seconds in sorted(TOTAL.items(), key=lambda kv: -kv[1]):
        print(f"{name:32s} {seconds:10.2f} {CALLS[name]:8d} {1e3 * seconds / CALLS[name]:14.3f}")


if __name__ == "__main__":
    main()
