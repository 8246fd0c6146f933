"""Reduced and thickness against full integration in the explicit solver (issue 16).

For each scene: one implicit run, the explicit run with full integration (the default),
with reduced integration (one point, hourglass control) and with thickness integration
(two points through the thickness, hourglass control), each explicit run compared
with the implicit one by ``forming compare --reuse`` (force-stroke RMS within 3% of the
peak, final shape within 2% of the core thickness). Also the cantilever of
``tests/test_hexforce.py`` for several hourglass coefficients. Writes
docs/validation.md's ``reduced`` section.

Run: ``python benchmarks/validate_reduced.py [--ranks 2]`` (about 20 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

from _report import REPO, machine, run_case_process, update_section

sys.path.insert(0, str(REPO / "tests"))

SCENES = (
    ("core_crushing", "core_crushing", ()),
    ("hemisphere with holder, 12 x 12 x 3", "hemisphere", ("blank_holder=true",
                                                         "cells=12,12,3")),
    ("hemisphere free, 12 x 12 x 3", "hemisphere", ("blank_holder=false", "cells=12,12,3",
                                                  "explicit.loading_time=0.1")),
)
KAPPAS = (0.01, 0.05, 0.1, 0.3)
INTEGRATIONS = ("full", "reduced", "thickness")  # 0: the hourglass modes are free (singular)


def compare_runs(case: str, sets: tuple[str, ...], out: Path) -> dict:
    cmd = [str(Path(sys.executable).parent / "forming"), "compare", case, "--out", str(out),
           "--reuse"]
    for s in sets:
        cmd += ["--set", s]
    proc = subprocess.run(cmd, cwd=REPO, env=dict(os.environ, OMP_NUM_THREADS="1"),
                          capture_output=True, text=True)
    if not (out / "compare.json").is_file():
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return json.loads((out / "compare.json").read_text())


def _smallest_det(run: Path, column: str = "min_det_F") -> float:
    """Smallest value of a history column over a run (nan where the run has none).

    ``min_det_F``: det F at the body's own (fully integrated) points; ``min_corner_det``:
    the determinant of the elements' maps at their corners over the reference.
    """
    with open(run / "history.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return min((float(r[column]) for r in rows if r.get(column)), default=float("nan"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--out", type=Path, default=REPO / "results" / "validate_reduced")
    parser.add_argument("--rerun", nargs="*", default=INTEGRATIONS,
                        help="integrations to run again; the others' runs in --out are "
                             "compared as they are (implicit runs are always reused)")
    args = parser.parse_args()
    rows = []
    for name, case, sets in SCENES:
        base = args.out / name.replace(" ", "_").replace(",", "")
        imp = base / "implicit"
        if not (imp / "summary.json").is_file():
            run_case_process(case, imp, args.ranks, sets=sets, allow_failure=True)
        for integration in INTEGRATIONS:
            folder = base / integration
            folder.mkdir(parents=True, exist_ok=True)
            link = folder / "implicit"
            if not link.exists():
                link.symlink_to(imp.resolve())
            done = folder / "explicit" / "summary.json"
            if integration in args.rerun or not done.is_file():
                run_case_process(case, folder / "explicit", args.ranks, allow_failure=True,
                                 sets=("solver=explicit", f"explicit.integration={integration}",
                                       *sets))
            s = json.loads(done.read_text())
            r = compare_runs(case, sets, folder)
            m = s["metrics"]
            rows.append({"scene": name, "integration": integration, "status": s["status"],
                         "force_rms": r["force_rms_diff_rel"],
                         "peak_diff": r.get("peak_force_diff_rel", float("nan")),
                         "shape_rms": r["shape_rms_diff_rel_thickness"],
                         "hourglass": m.get("hourglass_energy_fraction", 0.0),
                         "crushed": (r["metrics"].get("crushed_volume_mm3", {})),
                         "wall": s["timing"]["wall_s"],
                         "us": s["timing"].get("us_per_element_increment", float("nan")),
                         "min_det": _smallest_det(folder / "explicit"),
                         "corner": _smallest_det(folder / "explicit", "min_corner_det"),
                         "meets": r["meets_targets"]})
            print(rows[-1], flush=True)
    import dolfinx_solver  # noqa: F401  (PETSc and MPI before dolfinx)

    from test_hexforce import _cantilever

    beams = [(k, *_cantilever("reduced", k), *_cantilever("thickness", k)) for k in KAPPAS]
    beams.append(("full integration", *_cantilever("full", 0.0), float("nan"), 0.0))
    _report(rows, beams, args.ranks)


def _report(rows: list[dict], beams: list, ranks: int) -> None:
    lines = [
        "## Reduced and thickness integration in the explicit solver (issue 16)", "",
        f"`python benchmarks/validate_reduced.py --ranks {ranks}` on {machine()}. Each "
        "explicit run against one implicit run of the same scene (`forming compare "
        "--reuse`); targets 3% force RMS, 2% shape RMS. Hourglass: the largest hourglass "
        "over internal energy after 5% of the load (`metrics.hourglass_energy_fraction`). "
        "Cost: the time integration's wall time per element and increment "
        "(`timing.us_per_element_increment`, all elements of the scene). Smallest det F: "
        "over the run at the body's own fully integrated points (the history's "
        "`min_det_F`). Smallest corner det: the determinant of the elements' maps at "
        "their corners over the reference, smallest over the run (`min_corner_det`; at or "
        "below 0 an element has folded; - for a run made before it was recorded). The "
        "reduced and thickness runs hold their corners above 0.1 of the reference with "
        "the distortion control (`explicit.distortion_control`, 0.1 by default since "
        "2026-12-02; docs/theory.md, section 12).",
        "",
        "| scene | integration | status | force RMS diff | peak diff | shape RMS | hourglass "
        "/ internal | crushed volume imp. / exp. [mm^3] | smallest det F | smallest corner det "
        "| wall [s] | us / element / increment | targets |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        cv = r["crushed"]
        crushed = (f"{cv['implicit']:.0f} / {cv['explicit']:.0f}"
                   if isinstance(cv, dict) and cv else "-")
        corner = "-" if r["corner"] != r["corner"] else f"{r['corner']:.3f}"
        lines.append(
            f"| {r['scene']} | {r['integration']} | {r['status']} | {r['force_rms']:.2%} "
            f"| {r['peak_diff']:+.2%} | {r['shape_rms']:.2%} | {r['hourglass']:.1%} "
            f"| {crushed} | {r['min_det']:.3f} | {corner} | {r['wall']:.0f} | {r['us']:.2f} "
            f"| {'met' if r['meets'] else 'missed'} |")
    lines += [
        "", "Cantilever 100 x 10 x 10 mm, 40 x 2 x 4 elements, tip shear, static (the "
        "element loops' stiffness by central differences): tip deflection over "
        "Timoshenko's, hourglass over internal energy (targets 5% and 2%).", "",
        "| hourglass coefficient | reduced: deflection / beam theory | reduced: hourglass "
        "/ internal | thickness: deflection / beam theory | thickness: hourglass / "
        "internal |",
        "|---|---|---|---|---|",
    ]
    for k, ratio, hg, ratio2, hg2 in beams:
        second = "- | -" if ratio2 != ratio2 else f"{ratio2:.4f} | {hg2:.2%}"
        lines.append(f"| {k} | {ratio:.4f} | {hg:.2%} | {second} |")
    update_section("reduced", "\n".join(lines), REPO / "docs" / "validation.md")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
