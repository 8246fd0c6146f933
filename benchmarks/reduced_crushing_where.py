"""Where the core crushes under full and under reduced integration (issue 16).

Reduced integration leaves the explicit hemisphere's crushed volume 80-100% short
(docs/validation.md, reduced integration). This runs the scene of that table
(``hemisphere --set blank_holder=true --set cells=12,12,3 --set solver=explicit``) with
``explicit.integration=full`` and ``reduced`` in this process, and tabulates the core's
volumetric plastic strain at the end by element layer and by region: under the punch's
cap, between it and the die, over the die's edge radius, and on the flange. A cell counts
as crushed where one of its points passes 0.01 (the crushed volume's threshold).
Written to docs/validation.md (section ``reduced_where``).

Run: ``python benchmarks/reduced_crushing_where.py`` (about 3 minutes, serial).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from _report import REPO, machine, update_section

sys.path.insert(0, str(REPO))

VALIDATION_MD = REPO / "docs" / "validation.md"
SETS = ("blank_holder=true", "cells=12,12,3", "solver=explicit")
THRESHOLD = 0.01  # the crushed volume's threshold (forming.post.crushed_volume)


def final_strain(integration: str) -> tuple[np.ndarray, np.ndarray, dict]:
    """Each core cell's centre and its points' volumetric plastic strain at the end."""
    from forming.case import load_case, prepare_case
    from forming.simulation import Simulation

    module = load_case("hemisphere")
    sets = [*SETS, f"explicit.integration={integration}"]
    job, params = prepare_case("hemisphere", sets, module.build, module.Params)
    with tempfile.TemporaryDirectory() as out:
        sim = Simulation(job, Path(out), "hemisphere", {}, sets)
        sim.run()
    body = sim.model.body
    cells = body.point_cells
    evp = body.plastic.evp.reshape(len(cells), -1)
    x = body.mesh.geometry.x
    centres = x[body.mesh.geometry.dofmaps[0][cells]].mean(axis=1)
    return centres, evp, params


def regions(params: dict) -> list[tuple[str, float, float]]:
    """Radial bands of the scene [mm]: (name, inner radius, outer radius)."""
    punch, die, edge = (params["punch_diameter"] / 2, params["die_diameter"] / 2,
                        params["edge_radius"])
    return [(f"under the punch's cap (r < {punch:g})", 0.0, punch),
            (f"between punch and die ({punch:g}-{die:g})", punch, die),
            (f"over the die's edge radius ({die:g}-{die + edge:g})", die, die + edge),
            (f"flange (r > {die + edge:g})", die + edge, np.inf)]


def main() -> None:
    import forming  # noqa: F401  (PETSc before dolfinx)

    runs = {name: final_strain(name) for name in ("full", "reduced")}
    centres, _, params = runs["full"]
    r = np.hypot(centres[:, 0], centres[:, 1])
    z = centres[:, 2]
    layers = np.unique(np.round(z, 6))
    lines = ["## Where the core crushes: full against reduced integration (issue 16)", "",
             f"`python benchmarks/reduced_crushing_where.py` on {machine()}: `hemisphere "
             + " ".join(f"--set {s}" for s in SETS) + "` with `explicit.integration=full` "
             "and `reduced`, the core's volumetric plastic strain at the end of the stroke "
             "by element layer (z of the cell centres; 0 is the face on the die) and region. "
             f"Crushed cells: cells with a point past {THRESHOLD:g}. Largest and smallest: "
             "over the points (negative: plastic dilation).", "",
             "| layer | region | cells | crushed cells full / reduced | largest full / "
             "reduced | smallest full / reduced |", "|---|---|---:|---|---|---|"]
    for layer in layers:
        in_layer = np.isclose(z, layer, atol=1e-6)
        for name, lo, hi in regions(params):
            sel = in_layer & (r >= lo) & (r < hi)
            if not sel.any():
                continue
            ev = {k: v[1][sel] for k, v in runs.items()}
            crushed = " / ".join(str(int(np.count_nonzero((e > THRESHOLD).any(axis=1))))
                                 for e in ev.values())
            lines.append(f"| {layer:.2f} | {name} | {int(sel.sum())} | {crushed} | "
                         + " / ".join(f"{e.max():.4f}" for e in ev.values()) + " | "
                         + " / ".join(f"{e.min():.4f}" for e in ev.values()) + " |")
    update_section("reduced_where", "\n".join(lines), VALIDATION_MD)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
