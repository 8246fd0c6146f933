"""Finite-sliding verification for docs/validation.md: the large-slip sled.

A fabric (50 x 48 mm, 5 mm elements) under 2 kPa is dragged 70 mm (5.6 core element
lengths) over a core (200 x 50 x 10 mm, 12.5 mm elements), meshes not matching
(cases/sliding_sled.py), with load steps of at most 0.05 and 0.02: the drag over the
normal force once sliding, the normal force, the largest penetration and the cost.

Then ``hemisphere`` with skins and blank holder, small against finite sliding, on the
8 x 8 x 2 and 12 x 12 x 3 quarter meshes.

Run: ``python benchmarks/validate_sliding.py`` (about 10 minutes; ``--only sled`` or
``--only hemisphere`` for one part).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, machine, update_section

from forming.case import run_case

MU, AREA = 0.52, 50.0 * 48.0  # the case's friction and fabric area [mm^2]


def hemisphere() -> list[str]:
    """``hemisphere`` with skins and holder: small against finite sliding, two meshes."""
    lines = ["## Finite sliding: the hemisphere with skins", "",
             f"`python benchmarks/validate_sliding.py --only hemisphere` on {machine()}: "
             "`hemisphere --set skins=true --set blank_holder=true`, the skins paired node to "
             "node with the core (`skin_contact=small`, one conforming mesh) or meshed apart "
             "and sliding (`skin_contact=finite`, the same element size):", "",
             "| mesh | skin contact | status | punch force at 50 mm [N] | shear range top skin "
             "[deg] | largest skin-core slip [mm] | slip warning | steps (rejected) | Newton "
             "iterations | wall [s] |", "|---|---|---|---|---|---|---|---|---|---|"]
    sets = ("skins=true", "blank_holder=true")
    with tempfile.TemporaryDirectory() as tmp:
        for cells in ("8,8,2", "12,12,3"):
            for contact in ("small", "finite"):
                out = Path(tmp) / f"h{cells}{contact}"
                s = run_case("hemisphere", out, [*sets, f"cells={cells}",
                                                 f"skin_contact={contact}"])
                m, tm = s["metrics"], s["timing"]
                warned = any("small-sliding pairing" in w for w in s.get("warnings", []))
                lines.append(
                    f"| {cells} | {contact} | {s['status']} | {m['punch_force_final_N']:.0f} "
                    f"| {m['shear_min_deg_skin_top']:.1f} to {m['shear_max_deg_skin_top']:.1f} "
                    f"| {m['skin_core_slip_max_mm']:.1f} | {'yes' if warned else 'no'} "
                    f"| {tm['steps']} ({tm['rejected_steps']}) | {tm['newton_iterations']} "
                    f"| {tm['wall_s']:.0f} |")
    return lines


def sled() -> list[str]:
    """The large-slip sled with two largest load steps."""
    lines = ["## Finite sliding: the large-slip sled", "",
             f"`python benchmarks/validate_sliding.py --only sled` on {machine()}: a fabric "
             "(50 x 48 mm, 5 mm elements, NCF) under 2 kPa dragged 70 mm, 5.6 core element "
             "lengths, over a core (200 x 50 x 10 mm, 12.5 mm elements) on non-matching "
             "meshes, friction 0.52 (node to surface, `Scene.sliding`). Ratio: the force "
             "the core puts on the fabric along x over the normal force, at every step "
             "after 3.5 mm.", "",
             "| largest step | steps (rejected) | Newton iterations | ratio / 0.52 - 1 (min, max) "
             "| normal force / load - 1 | largest penetration [mm] (tolerance 0.004) "
             "| wall [s] |", "|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for largest in (0.05, 0.02):
            out = Path(tmp) / f"sled{largest}"
            s = run_case("sliding_sled", out, [f"max_step={largest}"])
            h = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
            sliding = h["t"] > 0.05
            normal = h["sliding_skin_z_N"][sliding]
            ratio = -h["sliding_skin_x_N"][sliding] / normal / MU - 1.0
            tm = s["timing"]
            lines.append(f"| {largest} | {tm['steps']} ({tm['rejected_steps']}) "
                         f"| {tm['newton_iterations']} | {ratio.min():+.1e}, {ratio.max():+.1e} "
                         f"| {np.abs(normal / (0.002 * AREA) - 1).max():.1e} "
                         f"| {h['sliding_skin_penetration_mm'].max():.2e} "
                         f"| {tm['wall_s']:.1f} |")
    return lines + ["", "Rejected steps: the first Newton iterate of a drag step inverted "
                    "fabric elements (the stick linearisation holds the fabric's bottom while "
                    "its top moves); the step is cut and retried."]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", choices=("sled", "hemisphere"))
    only = parser.parse_args().only
    for name, part in (("sliding", sled), ("sliding_hemisphere", hemisphere)):
        if only in (None, name.removeprefix("sliding_").replace("sliding", "sled")):
            lines = part()
            update_section(name, "\n".join(lines), REPO / "docs" / "validation.md")
            print("\n".join(lines))


if __name__ == "__main__":
    main()
