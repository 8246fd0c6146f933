"""Time the quadrature-point kernels: microseconds per point, with the tangent.

Compares the kernels of the working tree ("new") with those of a git revision
("old", default ``HEAD``) on the same points and plastic history, through
:func:`forming.materials.solids.evaluate`, and checks that both give the same
results. Run with a fresh numba cache, e.g.
``NUMBA_CACHE_DIR=/tmp/numba_kspeed python benchmarks/kernel_speed.py``.
"""

from __future__ import annotations

import argparse
import importlib.util
import io
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

from forming.materials import kernels as new_kernels
from forming.materials import solids
from forming.materials.library import honeycomb_core

ROOT = Path(__file__).resolve().parent.parent
KERNELS = "forming/materials/kernels"  # a package; a single ``kernels.py`` up to 76612de


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True)


def load_old_kernels(rev: str, tmp: Path):
    """Import the kernels of git revision ``rev`` under the name ``kernels_old``.

    The kernels are a package (imported from a ``git archive`` of its folder, so its
    relative imports stay within the old revision) or, in older revisions, a single
    module ``kernels.py``.
    """
    if _git("cat-file", "-t", f"{rev}:{KERNELS}").stdout.strip() == b"tree":
        tar = _git("archive", "--format=tar", rev, KERNELS)
        tar.check_returncode()
        with tarfile.open(fileobj=io.BytesIO(tar.stdout)) as archive:
            archive.extractall(tmp, filter="data")
        package = tmp / KERNELS
        spec = importlib.util.spec_from_file_location(
            "kernels_old", package / "__init__.py", submodule_search_locations=[str(package)])
    else:
        show = _git("show", f"{rev}:{KERNELS}.py")
        show.check_returncode()
        path = tmp / "kernels_old.py"
        path.write_bytes(show.stdout)
        spec = importlib.util.spec_from_file_location("kernels_old", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["kernels_old"] = module
    spec.loader.exec_module(module)
    return module


def random_cmats(n: int, seed: int = 0) -> np.ndarray:
    """``n`` right Cauchy-Green tensors ``F^T F``, ``F = I + 0.15 N(0, 1)``, ``det F > 0.05``."""
    rng = np.random.default_rng(seed)
    out = np.empty((n, 9))
    k = 0
    while k < n:
        f = np.eye(3) + 0.15 * rng.standard_normal((3, 3))
        if np.linalg.det(f) > 0.05:
            out[k] = (f.T @ f).reshape(9)
            k += 1
    return out


def evaluate_with(kernels, material, cmats, ep, evp) -> tuple[float, solids.PointResult]:
    """Wall time [s] and result of ``evaluate(..., want_tangent=True)`` with ``kernels``."""
    solids.kernels = kernels
    try:
        t0 = time.perf_counter()
        res = solids.evaluate(material, cmats, ep, evp, want_tangent=True)
        return time.perf_counter() - t0, res
    finally:
        solids.kernels = new_kernels


def compare(old_kernels, material, cmats, ep, evp, repeats: int) -> tuple[float, float, bool]:
    """Best time per point [us] of the old and the new kernels, and whether they agree.

    The runs alternate and the best of ``repeats`` counts, which keeps the ratio
    robust to other load on the machine.
    """
    for kernels in (old_kernels, new_kernels):  # compile or load from cache
        evaluate_with(kernels, material, cmats[:10], ep[:10], evp[:10])
    best_old = best_new = np.inf
    for _ in range(repeats):
        t_old, r_old = evaluate_with(old_kernels, material, cmats, ep, evp)
        t_new, r_new = evaluate_with(new_kernels, material, cmats, ep, evp)
        best_old, best_new = min(best_old, t_old), min(best_new, t_new)
    same = all(np.array_equal(a, b) for a, b in zip(r_old[:4], r_new[:4], strict=True)
               if a is not None)
    n = cmats.shape[0]
    return 1e6 * best_old / n, 1e6 * best_new / n, same


def main() -> None:
    """Print us/point for old and new kernels for each honeycomb-core material."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--old", default="HEAD", help="git revision of the old kernels")
    args = parser.parse_args()

    cm0 = random_cmats(args.points, seed=0)
    # history: one step from the virgin state, then time a step from its result
    rng = np.random.default_rng(1)
    pert = 0.02 * rng.standard_normal((args.points, 3, 3))
    cm1 = cm0 + 0.5 * (pert + pert.transpose(0, 2, 1)).reshape(-1, 9)
    materials = {
        "foam transverse": honeycomb_core("transverse"),
        "foam isotropic": honeycomb_core("isotropic"),
        "elastic": honeycomb_core(plastic=False),
    }
    with tempfile.TemporaryDirectory() as tmp:
        old_kernels = load_old_kernels(args.old, Path(tmp))
        print(f"{'material':18s} {'old us/pt':>10s} {'new us/pt':>10s} {'speed-up':>9s}  "
              "same results")
        for name, mat in materials.items():
            r0 = solids.evaluate(mat, cm0, want_tangent=False)
            ep = r0.ep if r0.ep is not None else np.zeros((args.points, 6))
            evp = r0.evp if r0.evp is not None else np.zeros(args.points)
            t_old, t_new, same = compare(old_kernels, mat, cm1, ep, evp, args.repeats)
            print(f"{name:18s} {t_old:10.2f} {t_new:10.2f} {t_old / t_new:8.2f}x  {same}",
                  flush=True)


if __name__ == "__main__":
    main()
