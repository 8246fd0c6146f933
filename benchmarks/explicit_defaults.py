"""Every shipped case run explicitly with its defaults: is the answer quasi-static?

A user who types ``--set solver=explicit`` and nothing else gets the case's default
loading time. This runs each case that way (serial, default mesh) and tabulates the
run's own checks: kinetic over internal energy (quasi-static below 5%), energy balance,
mass added, hourglass energy, and the cost. Writes docs/validation.md's
``explicit_defaults`` section; exits 1 if a completed default run is not quasi-static
or a run fails.

Run: ``python benchmarks/explicit_defaults.py [--only CASE ...]`` (long: the fabric-only
cases need of the order of 10^5 increments at their fibres' stable step).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from _report import REPO, machine, run_case_process, update_section

CASES = ("core_compression", "core_tension", "core_shear", "core_crushing", "strip_bending",
         "sandwich_bending", "skin_sled", "hemisphere", "hemisphere_free", "picture_frame",
         "bias_extension")
VARIANTS = {"hemisphere": ("hemisphere", ("blank_holder=true",)),
            "hemisphere_free": ("hemisphere", ("blank_holder=false",))}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--json", type=Path, default=None,
                        help="rows file: read first (rows of cases not run are kept), then "
                             "written")
    args = parser.parse_args()
    rows = {}
    if args.json is not None and args.json.is_file():
        rows = json.loads(args.json.read_text())
    with tempfile.TemporaryDirectory() as tmp:
        for name in CASES:
            if args.only and name not in args.only:
                continue
            case, sets = VARIANTS.get(name, (name, ()))
            out = Path(tmp) / name
            s = run_case_process(case, out, sets=("solver=explicit", *sets),
                                 allow_failure=True)
            m, t = s["metrics"], s["timing"]
            rows[name] = {"status": s["status"], "loading_time": t["loading_time_s"],
                          "ke_ie": m.get("kinetic_to_internal_max", float("nan")),
                          "quasi_static": bool(m.get("quasi_static", False)),
                          "balance": m.get("energy_balance_error_rel", float("nan")),
                          "hourglass": m.get("hourglass_energy_fraction", 0.0),
                          "increments": t["time_steps"], "wall": t["wall_s"],
                          "reason": s.get("reason") or ""}
            print(name, rows[name], flush=True)
            if args.json is not None:
                args.json.write_text(json.dumps(rows, indent=1))
    lines = [
        "## Default explicit runs: quasi-static? (issue 16, item 4)", "",
        f"`python benchmarks/explicit_defaults.py` on {machine()}: every shipped case with "
        "`--set solver=explicit` and nothing else (default mesh and loading time, serial).",
        "", "| case | status | loading time [s] | increments | KE/IE max | quasi-static "
        "| energy balance | wall [s] |", "|---|---|---|---|---|---|---|---|"]
    bad = []
    for name in CASES:
        r = rows.get(name)
        if r is None:
            continue
        lines.append(f"| {name} | {r['status']} | {r['loading_time']:g} | {r['increments']} "
                     f"| {r['ke_ie']:.2%} | {'yes' if r['quasi_static'] else 'no'} "
                     f"| {r['balance']:.1e} | {r['wall']:.0f} |")
        if r["status"] != "completed":
            bad.append(f"{name} ({r['status']}: {r['reason']})")
        elif not r["quasi_static"]:
            bad.append(f"{name} (KE/IE {r['ke_ie']:.0%})")
    missing = [n for n in CASES if n not in rows]
    lines += ["", "Not quasi-static or not completed: " + (", ".join(bad) if bad else "none")
              + "." + (f" Not run yet: {', '.join(missing)}." if missing else "")]
    update_section("explicit_defaults", "\n".join(lines), REPO / "docs" / "validation.md")
    print("\n".join(lines))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
