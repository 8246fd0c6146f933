"""Every shipped case run explicitly with its defaults: is the answer quasi-static?

A user who types ``--set solver=explicit`` and nothing else gets the case's default
loading time. This runs each case that way (serial, default mesh) and tabulates the
run's own checks: kinetic over internal energy (quasi-static below 5%), energy balance,
mass added, hourglass energy, and the cost. Writes docs/validation.md's
``explicit_defaults`` section; exits 1 if a completed default run is not quasi-static
or a run fails.

Run: ``python benchmarks/explicit_defaults.py [--only CASE ...]`` (long: the fabric-only
cases need of the order of 10^5 increments at their fibres' stable step). To refresh one
row without rerunning the others: ``--keep-table --only CASE``; to take a row from a
default explicit run made elsewhere (``forming compare CASE`` makes one):
``--keep-table --reuse CASE=FOLDER``. A reused row is footnoted with its folder.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from pathlib import Path

from _report import REPO, machine, run_case_process, update_section

CASES = ("core_compression", "core_tension", "core_shear", "core_crushing", "strip_bending",
         "sandwich_bending", "skin_sled", "hemisphere", "hemisphere_free", "picture_frame",
         "bias_extension")
VARIANTS = {"hemisphere": ("hemisphere", ("blank_holder=true",)),
            "hemisphere_free": ("hemisphere", ("blank_holder=false",))}


SECTION = REPO / "docs" / "validation.md"


def _row(s: dict) -> dict:
    """One table row from a run's ``summary.json``."""
    m, t = s["metrics"], s["timing"]
    return {"status": s["status"], "loading_time": t["loading_time_s"],
            "ke_ie": m.get("kinetic_to_internal_max", float("nan")),
            "quasi_static": bool(m.get("quasi_static", False)),
            "balance": m.get("energy_balance_error_rel", float("nan")),
            "hourglass": m.get("hourglass_energy_fraction", 0.0),
            "increments": t["time_steps"], "wall": t["wall_s"],
            "reason": s.get("reason") or ""}


def _table_rows() -> tuple[dict[str, dict], str]:
    """The rows of the section as it stands in docs/validation.md, and its machine."""
    text = SECTION.read_text()
    body = text.split("<!-- BEGIN explicit_defaults -->")[1].split("<!-- END")[0]
    found = re.search(r"explicit_defaults.py` on (.*?): every shipped case", body)
    rows = {}
    for line in body.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 8 or cells[0] not in CASES:
            continue
        rows[cells[0]] = {"status": cells[1], "loading_time": float(cells[2]),
                          "increments": int(cells[3]),
                          "ke_ie": float(cells[4].rstrip("%")) / 100,
                          "quasi_static": cells[5] == "yes", "balance": float(cells[6]),
                          "hourglass": 0.0, "wall": float(cells[7]), "reason": ""}
    notes = re.findall(r"^- `(\w+)`: (.*)$", body, flags=re.M)  # a row's source
    for name, note in notes:
        if name in rows:
            rows[name]["source"] = note
    return rows, found.group(1) if found else machine()


def _reused(name: str, folder: Path) -> dict:
    """A row from a default explicit run of ``name`` made elsewhere, checked as such."""
    summary = folder / "summary.json"
    if not summary.is_file():
        raise SystemExit(f"--reuse {name}={folder}: no summary.json in {folder}")
    s = json.loads(summary.read_text())
    case, sets = VARIANTS.get(name, (name, ()))
    given = [a for a in (s.get("assignments") or []) if a != "solver=explicit"]
    if s.get("case") != case or s.get("solver") != "explicit" or sorted(given) != sorted(sets):
        raise SystemExit(
            f"--reuse {name}={folder}: the run is case {s.get('case')!r}, solver "
            f"{s.get('solver')!r}, settings {given}; a default explicit run of {case} "
            f"with {list(sets)} is needed")
    if s.get("ranks", 1) != 1:
        raise SystemExit(f"--reuse {name}={folder}: ran on {s['ranks']} ranks; the table "
                         "is serial")
    return _row(s) | {"source": f"taken from the serial run in `{folder}` "
                                f"(forming {s['versions'].get('forming', '?')}), "
                                "not run by this script"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--json", type=Path, default=None,
                        help="rows file: read first (rows of cases not run are kept), then "
                             "written")
    parser.add_argument("--keep-table", action="store_true",
                        help="start from the rows of the table in docs/validation.md")
    parser.add_argument("--reuse", action="append", default=[], metavar="CASE=FOLDER",
                        help="take CASE's row from the default explicit run in FOLDER")
    args = parser.parse_args()
    rows, where = _table_rows() if args.keep_table else ({}, machine())
    if args.json is not None and args.json.is_file():
        rows |= json.loads(args.json.read_text())
    for item in args.reuse:
        name, _, folder = item.partition("=")
        if name not in CASES or not folder:
            raise SystemExit(f"--reuse {item!r}: expected CASE=FOLDER with CASE one of "
                             f"{', '.join(CASES)}")
        rows[name] = _reused(name, Path(folder))
    if args.only is not None:
        unknown = sorted(set(args.only) - set(CASES))
        if unknown:
            raise SystemExit(f"--only: unknown case(s) {unknown}; one of {CASES}")
    # With --keep-table or --reuse only the --only cases run (none without it).
    to_run = args.only if args.only is not None else (
        [] if args.keep_table or args.reuse else list(CASES))
    with tempfile.TemporaryDirectory() as tmp:
        for name in CASES:
            if name not in to_run:
                continue
            case, sets = VARIANTS.get(name, (name, ()))
            out = Path(tmp) / name
            s = run_case_process(case, out, sets=("solver=explicit", *sets),
                                 allow_failure=True)
            rows[name] = _row(s)
            if where != machine():
                rows[name]["source"] = f"rerun on {machine()}"
            print(name, rows[name], flush=True)
            if args.json is not None:
                args.json.write_text(json.dumps(rows, indent=1))
    lines = [
        "## Default explicit runs: quasi-static? (issue 16, item 4)", "",
        f"`python benchmarks/explicit_defaults.py` on {where}: every shipped case with "
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
    notes = [f"- `{n}`: {rows[n]['source']}" for n in CASES
             if n in rows and rows[n].get("source")]
    if notes:
        lines += ["", *notes]
    missing = [n for n in CASES if n not in rows]
    lines += ["", "Not quasi-static or not completed: " + (", ".join(bad) if bad else "none")
              + "." + (f" Not run yet: {', '.join(missing)}." if missing else "")]
    update_section("explicit_defaults", "\n".join(lines), SECTION)
    print("\n".join(lines))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
