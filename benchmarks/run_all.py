"""Run every benchmark in this folder (each updates its section of docs/performance.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
BENCHMARKS = ["core_compression.py", "kernel_speed.py", "hemisphere_cost.py",
              "accuracy_vs_time.py"]

if __name__ == "__main__":
    for name in BENCHMARKS:
        print(f"== {name}", flush=True)
        subprocess.run([sys.executable, str(HERE / name)], check=True)
