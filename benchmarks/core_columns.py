"""Where a crushed core folded: the tightest gap between stacked nodes of each column.

A core meshed in layers has its nodes in columns (the same x, y in the reference). At the
end of a run, a node that lies below the node beneath it has been pushed through the
layer under it: an element there is folded at its corners, whatever its quadrature
points say (docs/validation.md, "core_crushing with its plan refined").

Run: ``python benchmarks/core_columns.py RUN [RUN ...]`` with run folders holding a
``final_shape.npz`` (the last converged state of any run, failed ones too). Prints, per
run, the smallest current gap between successive nodes of a column [mm], that gap over
its reference one, and the column.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def tightest_gap(run: Path, body: str = "core") -> tuple[float, float, np.ndarray]:
    """(gap [mm], gap over its reference, the column's x, y) of a run's tightest column."""
    shape = np.load(run / "final_shape.npz")
    X, u = shape[f"{body}_X"], shape[f"{body}_u"]
    keys = np.round(X[:, :2], 6)
    order = np.lexsort((X[:, 2], keys[:, 1], keys[:, 0]))
    same = np.all(keys[order][1:] == keys[order][:-1], axis=1)
    gap = np.diff((X + u)[order, 2])[same]
    ratio = gap / np.diff(X[order, 2])[same]
    i = int(np.argmin(ratio))
    return float(gap[i]), float(ratio[i]), keys[order][:-1][same][i]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--body", default="core")
    args = parser.parse_args()
    for run in args.runs:
        gap, ratio, xy = tightest_gap(run, args.body)
        print(f"{run}: tightest gap {gap:.3f} mm ({ratio:.3f} of its reference) in the "
              f"column at x, y = {xy[0]:.2f}, {xy[1]:.2f} mm")


if __name__ == "__main__":
    main()
