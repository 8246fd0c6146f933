"""The walls' self-contact late in a crushing: increments per second, before and after.

Late in a meso compression the folds are packed and a few nodes, flung off cracked
cells, move fast: that is where the self-contact's candidate list costs most
(docs/theory.md, section 15). This benchmark restarts one run from its checkpoint with
this checkout and with ``--before`` (a checkout of an earlier revision: ``git worktree
add /tmp/old REV``), one after the other on 2 ranks, stops each with SIGINT after
``--seconds`` of wall time, and counts the increments each ran. The forces must not
change: the platen force at the last output step both reached is compared.

The default checkpoint is the 3 x 3 densification run of ``validate_meso_rve.py``
stopped at 0.64 strain, kept as ``results/validate_meso_rve/densify-3-3-at-0.64``
(copy a run folder there after stopping it with Ctrl-C to measure another state).

Writes docs/performance.md ``selfcontact_speed``; runs in ``results/selfcontact_speed``
(a rerun measures again).

Run: ``python benchmarks/selfcontact_speed.py --before /tmp/old`` (twice ``--seconds``
and start-up; nothing else should run meanwhile).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _report import REPO, machine, read_summary, revision, update_section

PERFORMANCE_MD = REPO / "docs" / "performance.md"
OUT = REPO / "results" / "selfcontact_speed"
SOURCE = REPO / "results" / "validate_meso_rve" / "densify-3-3-at-0.64"


def restart_for(source: Path, folder: Path, repo: Path, seconds: float, ranks: int) -> dict:
    """Restart a copy of ``source`` in ``folder`` with the checkout ``repo``; SIGINT after
    ``seconds``. Returns the summary it wrote."""
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(source, folder)
    cmd = [str(Path(sys.executable).parent / "mpirun"), "-n", str(ranks), sys.executable,
           "cases/meso_compression.py", "--restart", str(folder)]
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(repo))
    with open(folder.with_suffix(".log"), "w") as log:
        proc = subprocess.Popen(cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            proc.wait(timeout=seconds)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
            proc.wait()
    summary = read_summary(folder)
    if summary.get("status") not in ("interrupted", "completed"):
        raise RuntimeError(f"{' '.join(cmd)} did not stop as asked: see "
                           f"{folder.with_suffix('.log')}")
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True,
                        help="checkout of the earlier revision")
    parser.add_argument("--source", type=Path, default=SOURCE,
                        help="run folder with the checkpoint to restart from")
    parser.add_argument("--seconds", type=float, default=240.0,
                        help="wall time of each restart before SIGINT")
    parser.add_argument("--ranks", type=int, default=2)
    args = parser.parse_args()
    origin = read_summary(args.source)
    if "checkpoint" not in origin or not (args.source / "checkpoint.npz").is_file():
        sys.exit(f"{args.source} holds no checkpoint to restart from")
    start = origin["timing"]["work"]
    rows = {}
    for tag, repo in (("before", args.before.resolve()), ("after", REPO)):
        folder = OUT / tag
        t0 = time.perf_counter()
        summary = restart_for(args.source, folder, repo, args.seconds, args.ranks)
        h = np.atleast_1d(np.genfromtxt(folder / "history.csv", delimiter=",", names=True))
        rows[tag] = (revision(repo), summary, time.perf_counter() - t0, h)
    common = min(int(r[3]["step"][-1]) for r in rows.values())
    f_ref = rows["before"][3]
    force_ref = float(f_ref["reaction_top_z_N"][f_ref["step"] == common][0])
    m = origin["metrics"]
    lines = ["## Self-contact late in a crushing: before and after", "",
             "Written by `python benchmarks/selfcontact_speed.py --before <checkout>`; "
             f"{machine()}; the runs one after the other, nothing else running. "
             f"`meso_compression` restarted on {args.ranks} ranks from the checkpoint in "
             f"`{args.source.relative_to(REPO)}` (strain {m['final_strain']:.2f}, "
             f"{start} increments), stopped by SIGINT after {args.seconds:g} s of wall time "
             "(start-up included). Force: the platen's at the last output step both "
             f"reached (step {common}).", "",
             "| revision | increments run | increments per second | speed-up "
             "| strain reached | platen force at that step [N] | difference from before |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    base = None
    for tag in ("before", "after"):
        rev, summary, wall, h = rows[tag]
        done = summary["timing"]["work"] - start
        rate = done / wall
        base = base or rate
        force = float(h["reaction_top_z_N"][h["step"] == common][0])
        lines.append(f"| {rev} | {done} | {rate:.1f} | {rate / base:.2f} "
                     f"| {summary['metrics']['final_strain']:.4f} | {force:.10g} "
                     f"| {abs(force - force_ref) / abs(force_ref):.1e} |")
    update_section("selfcontact_speed", "\n".join(lines), PERFORMANCE_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
