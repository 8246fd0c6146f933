"""Run the speed benchmarks (most update their section of docs/performance.md; the
kernel and linear-solver ones print a table that the page quotes)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
BENCHMARKS = ["core_compression.py", "kernel_speed.py", "linear_solvers.py",
              "lu_precision.py", "hemisphere_cost.py", "accuracy_vs_time.py", "scaling_study.py",
              "explicit_speed.py", "surface_tools.py"]

if __name__ == "__main__":
    for name in BENCHMARKS:
        print(f"== {name}", flush=True)
        subprocess.run([sys.executable, str(HERE / name)], check=True)
