"""Time the quadrature-point kernels: microseconds per point, with the tangent.

Compares the kernels of the working tree ("new") with those of a git revision
("old") on the same points and plastic history, through
:func:`forming.materials.solids.evaluate`, on plastic points (a step from a crushed
state) and on elastic points (strains below 0.5%). It reports the largest difference
of their stresses and plastic states (0: the same bits; else the return mapping's
root tolerance, 1e-13 of the strength, where they find the root differently) and
the largest relative difference of their tangents (the old kernels' central
difference against the closed form). Run with a fresh numba cache and nothing else on
the machine, e.g. ``NUMBA_CACHE_DIR=/tmp/numba_kspeed python benchmarks/kernel_speed.py``.
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
    """Wall time [s] and result of ``evaluate(..., want_tangent=True)`` with ``kernels``.

    The old kernels take ``want_tangent=True`` as their (difference) tangent; the new
    ones as the closed form.
    """
    solids.kernels = kernels
    try:
        t0 = time.perf_counter()
        res = solids.evaluate(material, cmats, ep, evp, want_tangent=True)
        return time.perf_counter() - t0, res
    finally:
        solids.kernels = new_kernels


def compare(old_kernels, material, cmats, ep, evp, repeats: int):
    """Best time per point [us] of the old and the new kernels, and how they agree.

    The runs alternate and the best of ``repeats`` counts, which keeps the ratio
    robust to other load on the machine.

    Returns:
        (old us/point, new us/point, the largest difference of the stresses and plastic
        states relative to the largest value of each (0: the same bits), median
        over the points of the largest relative difference of their tangents: the
        difference tangent's truncation error; its maximum is of order 1 at the few
        points whose +/-h perturbations straddle the yield surface).
    """
    for kernels in (old_kernels, new_kernels):  # compile or load from cache
        evaluate_with(kernels, material, cmats[:10], ep[:10], evp[:10])
    best_old = best_new = np.inf
    for _ in range(repeats):
        t_old, r_old = evaluate_with(old_kernels, material, cmats, ep, evp)
        t_new, r_new = evaluate_with(new_kernels, material, cmats, ep, evp)
        best_old, best_new = min(best_old, t_old), min(best_new, t_new)
    same = max((float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1e-300)) for a, b in
                zip((r_old.S, r_old.ep, r_old.evp), (r_new.S, r_new.ep, r_new.evp), strict=True)
                if a is not None and a.size), default=0.0)
    d_diff = float(np.median(np.abs(r_old.D - r_new.D).max(axis=1)
                             / np.abs(r_old.D).max(axis=1)))
    n = cmats.shape[0]
    return 1e6 * best_old / n, 1e6 * best_new / n, same, d_diff


def elastic_cmats(n: int, seed: int = 2) -> np.ndarray:
    """``n`` tensors of strains below 0.5% (no point of either core yields)."""
    rng = np.random.default_rng(seed)
    a = 0.0005 * rng.standard_normal((n, 3, 3))
    f = np.eye(3)[None] + a + a.transpose(0, 2, 1)
    return np.einsum("nki,nkj->nij", f, f).reshape(n, 9)


def main() -> None:
    """Print us/point of old and new kernels, plastic and elastic points, each material."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--old", default="89ee46e",
                        help="git revision of the old kernels (default: the last one with "
                             "the difference tangent only)")
    args = parser.parse_args()

    cm0 = random_cmats(args.points, seed=0)
    # history: one step from the virgin state, then time a step from its result
    rng = np.random.default_rng(1)
    pert = 0.02 * rng.standard_normal((args.points, 3, 3))
    cm1 = cm0 + 0.5 * (pert + pert.transpose(0, 2, 1)).reshape(-1, 9)
    cm_el = elastic_cmats(args.points)
    materials = {
        "foam transverse": honeycomb_core("transverse"),
        "foam isotropic": honeycomb_core("isotropic"),
        "elastic transverse": honeycomb_core("transverse", plastic=False),
        "elastic isotropic": honeycomb_core("isotropic", plastic=False),
    }
    with tempfile.TemporaryDirectory() as tmp:
        old_kernels = load_old_kernels(args.old, Path(tmp))
        print("| material | points | old us/pt | new us/pt | speed-up | stress difference | "
              "tangent difference |\n|---|---|---|---|---|---|---|")
        for name, mat in materials.items():
            r0 = solids.evaluate(mat, cm0, want_tangent=False)
            ep = r0.ep if r0.ep is not None else np.zeros((args.points, 6))
            evp = r0.evp if r0.evp is not None else np.zeros(args.points)
            sets = {"elastic": (cm_el, np.zeros_like(ep), np.zeros_like(evp))}
            if mat.plastic:
                sets = {"plastic": (cm1, ep, evp)} | sets
            for label, (cm, e, v) in sets.items():
                if label == "plastic":
                    r = solids.evaluate(mat, cm, e, v, want_tangent=False)
                    label = f"plastic ({np.mean(r.evp != v):.0%} yield)"
                t_old, t_new, same, d_diff = compare(old_kernels, mat, cm, e, v, args.repeats)
                print(f"| {name} | {label} | {t_old:.2f} | {t_new:.2f} | {t_old / t_new:.1f}x | "
                      f"{same:.0e} | {d_diff:.1e} |", flush=True)


if __name__ == "__main__":
    main()
