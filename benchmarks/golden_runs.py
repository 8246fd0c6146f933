"""Regression snapshot: run a fixed set of coarse cases and compare with a reference set.

A refactoring that must not change results (the architecture issue, a kernel split)
is checked by running this once on the old tree and once on the new one:

    python benchmarks/golden_runs.py --out /tmp/golden_old          # on the old tree
    python benchmarks/golden_runs.py --out /tmp/golden_new --against /tmp/golden_old

Every run covers one path through the code: each core test, both contact cases, the
hemisphere with and without skins, the fabric cases, the skin-core interfaces and the
explicit solver. The comparison reports, per run, the largest relative difference of
every history column shared by both (0.0 means bit-for-bit) and the metrics that differ.
Wall-time columns are ignored.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import forming.compat  # noqa: F401
from forming.case import run_case

RUNS: dict[str, tuple[str, list[str]]] = {
    "core_compression": ("core_compression", []),
    "core_shear": ("core_shear", []),
    "core_tension": ("core_tension", ["direction=transverse"]),
    "core_crushing": ("core_crushing", ["cells=4,4,2", "stroke=4"]),
    "hemisphere_holder": ("hemisphere", ["cells=6,6,2", "stroke=8", "blank_holder=true"]),
    "hemisphere_skins": ("hemisphere", ["cells=6,6,2", "stroke=6", "skins=true",
                                        "skin_contact=small", "blank_holder=true"]),
    "picture_frame": ("picture_frame", ["cells=4,4,1", "shear_max_deg=40"]),
    "bias_extension": ("bias_extension", ["element=10", "shear_target_deg=30"]),
    "skin_sled": ("skin_sled", []),
    "sandwich_bending": ("sandwich_bending", ["deflection=4", "element=10"]),
    "explicit_crushing": ("core_crushing", ["cells=4,4,2", "stroke=4", "solver=explicit",
                                            "explicit.loading_time=0.01"]),
    "explicit_sled": ("skin_sled", ["solver=explicit", "explicit.loading_time=0.01"]),
}

IGNORED = ("step_wall_s", "wall_s", "jit_s", "kernel_s", "assembly_s")


def _history(folder: Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(folder / "history.csv", delimiter=",", names=True)
    return {k: np.atleast_1d(data[k]).astype(float) for k in data.dtype.names}


def _rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    if a.shape != b.shape:
        return float("inf")
    scale = max(float(np.max(np.abs(a), initial=0.0)), 1e-300)
    return float(np.max(np.abs(a - b), initial=0.0) / scale)


def compare(new: Path, old: Path) -> dict[str, dict]:
    """Per run: largest relative difference per history column, and differing metrics."""
    report = {}
    for name in RUNS:
        a_dir, b_dir = old / name, new / name
        if not (a_dir / "history.csv").is_file() or not (b_dir / "history.csv").is_file():
            report[name] = {"missing": True}
            continue
        ha, hb = _history(a_dir), _history(b_dir)
        cols = {k: _rel_diff(ha[k], hb[k]) for k in ha if k in hb and k not in IGNORED}
        ma = json.loads((a_dir / "summary.json").read_text())["metrics"]
        mb = json.loads((b_dir / "summary.json").read_text())["metrics"]
        metrics = {k: (ma[k], mb.get(k)) for k in ma if ma[k] != mb.get(k)}
        report[name] = {
            "max_rel_diff": max(cols.values(), default=0.0),
            "columns_differing": {k: v for k, v in cols.items() if v > 0},
            "columns_only_old": sorted(set(ha) - set(hb)),
            "columns_only_new": sorted(set(hb) - set(ha)),
            "metrics_differing": metrics,
        }
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--against", type=Path, default=None)
    parser.add_argument("--only", nargs="*", default=None, help="run names to run")
    args = parser.parse_args()
    for name, (case, sets) in RUNS.items():
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        s = run_case(case, args.out / name, sets)
        print(f"{name}: {s['status']} in {time.perf_counter() - t0:.1f} s", flush=True)
    if args.against is not None:
        report = compare(args.out, args.against)
        (args.out / "golden_compare.json").write_text(json.dumps(report, indent=2) + "\n")
        worst = {k: v.get("max_rel_diff", "missing") for k, v in report.items()}
        print(json.dumps(worst, indent=2))
        sys.exit(0 if all(v == 0.0 for v in worst.values()) else 1)


if __name__ == "__main__":
    main()
