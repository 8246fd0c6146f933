"""Where a run's Newton iterations go: the slow steps, their residuals and active sets.

Runs a case in this process through the step API (serial) and records, for every
attempted load step, its Newton residuals over the step's tolerance (``atol``, from
``newton.force_rtol`` of the last step's force) and, for a plastic solid body, how
many of its quadrature points are plastic at each iterate and how many turned plastic
or elastic since the iterate before (the trial state of the point kernel, against the
converged state of the last step). Prints the iterations of the steps that took at most
``--easy`` iterations, of the others and of the failed ones, and one row per slow or
failed step. It times nothing: run it beside other work if need be.

Run: ``python benchmarks/newton_tail.py`` (the hemisphere without holder, about a
minute); any case and settings: ``python benchmarks/newton_tail.py core_crushing --set
cells=8,8,6``.
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.case import prepare_case
from forming.simulation import Simulation


@dataclass
class Attempt:
    """One attempted load step."""

    t: float
    converged: bool = False
    iterations: int = 0
    atol: float = 0.0
    residuals: list[float] = field(default_factory=list)
    plastic: list[int] = field(default_factory=list)
    turned_on: list[int] = field(default_factory=list)
    turned_off: list[int] = field(default_factory=list)
    reason: str = ""


class Recorder:
    """SNES monitor: residual and plastic active set of every iterate."""

    def __init__(self, sim: Simulation):
        self.sim = sim
        snes = sim.solver.problem.solver
        self.snes = snes
        self.state = next((b.plastic for b in sim.model.bodies.values()
                           if getattr(b, "plastic", None) is not None), None)
        self.attempt: Attempt | None = None
        self._previous: np.ndarray | None = None
        snes.setMonitor(self._monitor)

    def begin(self, t: float) -> None:
        self.attempt = Attempt(t)
        self._previous = None

    def _monitor(self, snes, its: int, norm: float) -> None:
        a = self.attempt
        if its == 0:
            a.atol = snes.getTolerances()[1]
            a.t = self.sim.model.t  # the load the step is solved for
        a.residuals.append(float(norm))
        if self.state is None:
            return
        s = self.state
        now = (s.evp_trial != s.evp) | np.any(s.ep_trial != s.ep, axis=1)
        a.plastic.append(int(now.sum()))
        prev = self._previous
        a.turned_on.append(0 if prev is None else int(np.count_nonzero(now & ~prev)))
        a.turned_off.append(0 if prev is None else int(np.count_nonzero(prev & ~now)))
        self._previous = now


def ratios(a: Attempt) -> str:
    """Residuals over the step's tolerance, two digits."""
    return " ".join(f"{r / a.atol:.2g}" for r in a.residuals) if a.atol > 0 else ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("case", nargs="?", default="hemisphere")
    parser.add_argument("--set", action="append", dest="assignments", default=None,
                        metavar="KEY=VALUE")
    parser.add_argument("--easy", type=int, default=4,
                        help="steps with at most this many iterations count as easy")
    args = parser.parse_args()
    assignments = (args.assignments if args.assignments is not None
                   else ["blank_holder=false"] if args.case == "hemisphere" else [])
    job, params = prepare_case(args.case, assignments)
    attempts: list[Attempt] = []
    with tempfile.TemporaryDirectory() as tmp:
        sim = Simulation(job, Path(tmp), args.case, params, assignments)
        try:
            rec = Recorder(sim)
            sim.start()
            while not sim.done:
                rec.begin(sim.stepper.t)
                res = sim.step()
                a = rec.attempt
                a.converged, a.iterations, a.reason = res.converged, res.work, res.reason
                attempts.append(a)
            summary = sim.finish()
        finally:
            sim.solver.close()
    ok = [a for a in attempts if a.converged]
    easy = sum(a.iterations for a in ok if a.iterations <= args.easy)
    slow = sum(a.iterations for a in ok if a.iterations > args.easy)
    failed = sum(a.iterations for a in attempts if not a.converged)
    total = easy + slow + failed
    print(f"{args.case} {' '.join(assignments)}: {summary['status']}, {len(ok)} steps, "
          f"{len(attempts) - len(ok)} failed attempts, {total} Newton iterations")
    print(f"- in steps of at most {args.easy} iterations: {easy} "
          f"({sum(a.iterations <= args.easy for a in ok)} steps)")
    print(f"- in slower steps: {slow} ({sum(a.iterations > args.easy for a in ok)} steps)")
    print(f"- in failed attempts: {failed}")
    print()
    print("| load parameter | converged | iterations | residual / tolerance at each iterate "
          "| plastic points (turned plastic / elastic) |")
    print("|---|---|---:|---|---|")
    for a in attempts:
        if a.converged and a.iterations <= args.easy:
            continue
        flips = " ".join(f"{p} (+{on}/-{off})" for p, on, off
                         in zip(a.plastic, a.turned_on, a.turned_off, strict=True))
        print(f"| {a.t:.5f} | {'yes' if a.converged else 'no: ' + a.reason[:40]} | "
              f"{a.iterations} | {ratios(a)} | {flips} |")


if __name__ == "__main__":
    main()
