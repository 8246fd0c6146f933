"""Adaptive against full integration in the explicit solver: accuracy and cost (issue 16).

The scenes of ``validate_reduced.py`` (core_crushing on its shipped 8 x 8 x 6 mesh, the
hemisphere with and without holder on 12 x 12 x 3). For each: the implicit run (reused
from ``--out`` when there), then the explicit run with full integration and with
adaptive integration, one after the other, each alone; each explicit run compared with
the implicit one by ``forming compare --reuse`` (targets: force RMS 3%, shape RMS 2%).
The cost ratio is full over adaptive time per element and increment of the same
invocation. Writes docs/validation.md's ``adaptive`` section.

Run: ``python benchmarks/validate_adaptive.py`` (about 20 minutes on 2 cores, with the
implicit runs already in ``--out``; run nothing else meanwhile).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from _report import REPO, machine, run_case_process, update_section
from validate_reduced import SCENES, compare_runs

INTEGRATIONS = ("full", "adaptive")


def _row(name: str, integration: str, folder, case: str, sets: tuple[str, ...]) -> dict:
    s = json.loads((folder / "explicit" / "summary.json").read_text())
    r = compare_runs(case, (*sets, f"explicit.integration={integration}"), folder)
    m, cv = s["metrics"], r["metrics"].get("crushed_volume_mm3", {})
    return {"scene": name, "integration": integration, "status": s["status"],
            "force_rms": r["force_rms_diff_rel"], "peak": r["peak_force_diff_rel"],
            "shape_rms": r["shape_rms_diff_rel_thickness"],
            "hourglass": m.get("hourglass_energy_fraction", 0.0),
            "full": m.get("full_integration_fraction", 1.0 if integration == "full" else 0.0),
            "crushed": f"{cv['explicit']:.0f} / {cv['implicit']:.0f}" if cv else "-",
            "us": s["timing"]["us_per_element_increment"], "wall": s["timing"]["wall_s"],
            "increments": s["timing"]["time_steps"], "meets": r["meets_targets"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(REPO / "results" / "validate_reduced"),
                        help="folder of validate_reduced.py's runs (its implicit runs "
                             "are reused)")
    args = parser.parse_args()
    out = Path(args.out)
    rows = []
    for name, case, sets in SCENES:
        base = out / name.replace(" ", "_").replace(",", "")
        imp = base / "implicit"
        if not (imp / "summary.json").is_file():
            run_case_process(case, imp, 1, sets=sets, allow_failure=True)
        for integration in INTEGRATIONS:
            folder = base / f"{integration}_cost"
            folder.mkdir(parents=True, exist_ok=True)
            if not (folder / "implicit").exists():
                (folder / "implicit").symlink_to(imp.resolve())
            run_case_process(case, folder / "explicit", 1, allow_failure=True,
                             sets=("solver=explicit", f"explicit.integration={integration}",
                                   *sets))
            rows.append(_row(name, integration, folder, case, sets))
            print(rows[-1], flush=True)
    _report(rows)


def _report(rows: list[dict]) -> None:
    lines = [
        "## Adaptive integration in the explicit solver (issue 16)", "",
        f"`python benchmarks/validate_adaptive.py` on {machine()}, each run alone: the "
        "scenes of the table above, explicit with full and with adaptive integration "
        "(`explicit.integration=adaptive`: thickness integration, full integration for "
        "good in each element that crushes unevenly; docs/theory.md, section 12), each "
        "against the implicit run (`forming compare --reuse`; targets 3% force RMS, 2% "
        "shape RMS). Full at end: the share of the core's elements fully integrated at the "
        "end (`metrics.full_integration_fraction`). Cost: "
        "`timing.us_per_element_increment`; the ratio is full over adaptive, same scene, "
        "same invocation.", "",
        "| scene | integration | status | force RMS | peak | shape RMS | hourglass / "
        "internal | full at end | crushed volume exp. / imp. [mm^3] | increments | wall [s] "
        "| us / element / increment | full / adaptive | targets |",
        "|---|---|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---|",
    ]
    us_full = {r["scene"]: r["us"] for r in rows if r["integration"] == "full"}
    for r in rows:
        ratio = (f"{us_full[r['scene']] / r['us']:.2f}"
                 if r["integration"] == "adaptive" and r["scene"] in us_full else "")
        lines.append(
            f"| {r['scene']} | {r['integration']} | {r['status']} | {r['force_rms']:.2%} "
            f"| {r['peak']:+.1%} | {r['shape_rms']:.2%} | {r['hourglass']:.1%} "
            f"| {r['full']:.0%} | {r['crushed']} | {r['increments']:,} | {r['wall']:.0f} "
            f"| {r['us']:.2f} | {ratio} | {'met' if r['meets'] else 'missed'} |")
    update_section("adaptive", "\n".join(lines), REPO / "docs" / "validation.md")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
