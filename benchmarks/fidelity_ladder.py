"""The fidelity ladder of the hemisphere with skins: what each level of accuracy costs.

`hemisphere` with skins and blank holder, from the cheapest model to the dearest:

1. the kinematic drape onto the punch (``forming drape``, net spacing: the default mesh's
   element size), timed as a process;
2. the macro model, implicit, on the quarter meshes 12 x 12 x 3, 16 x 16 x 4 and the
   default 20 x 20 x 4 (the reference, the finest FE result);
3. the macro model, explicit, on 12 x 12 x 3;
4. the meso model: not yet (issue 20).

The FE runs are ``forming study`` runs on 2 ranks each, one at a time, in ``--work``
(``results/fidelity_ladder``): a rerun reuses what is there. For every level: wall time,
the top skin's shear range, the RMS difference of its shear field to the reference's
(material point by material point, :mod:`forming.post.skinfield`; over the whole skin
and over the part the drape covers, the skin on the punch), and the punch force's
difference. The drape's difference by distance from the pole says where it stops being
good enough. Writes docs/figures/fidelity_ladder.png (difference against wall time),
fidelity_ladder_maps.png (the shear maps) and, with ``--write``, the ``fidelity_ladder``
section of docs/performance.md.

Run alone (wall times): ``python benchmarks/fidelity_ladder.py --write`` (about 40 minutes
on 2 cores from nothing; seconds when the runs are in ``--work``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from _report import REPO, machine, study_runs, update_section

sys.path.insert(0, str(REPO))
from forming.post.skinfield import CellField, DrapeField, rms  # noqa: E402

SETS = ("skins=true", "blank_holder=true")
IMPLICIT = ("12,12,3", "16,16,4", "20,20,4")
EXPLICIT = ("12,12,3",)
METRICS = ("punch_force_max_N", "shear_min_deg_skin_top", "shear_max_deg_skin_top")
SKIN = "skin_top"  # the skin on the punch (the drape's surface)
BANDS = (0.0, 20.0, 40.0, 60.0, 80.0, 120.0)  # distance from the pole in the flat blank [mm]
FIG = REPO / "docs" / "figures"


@dataclass(frozen=True)
class Level:
    """One rung: its label, wall time, shear field source and punch force."""

    label: str
    wall_s: float
    unknowns: int
    field: CellField | DrapeField
    shear_range: tuple[float, float]
    force_N: float | None
    folder: Path


def drape_level(work: Path, case: str = "hemisphere",
                args: tuple[str, ...] = tuple(a for s in SETS for a in ("--set", s))) -> Level:
    """``forming drape CASE ARGS`` into ``work/drape``, timed as a process."""
    out = work / "drape"
    cmd = [str(Path(sys.executable).parent / "forming"), "drape", case, "--out",
           str(out), *args]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=REPO)
    wall = time.perf_counter() - t0
    rec = json.loads((out / "drape.json").read_text())
    field = DrapeField.from_drape_json(out)
    return Level(f"kinematic drape, d = {rec['settings']['spacing']:.3g} mm", wall, 0,
                 field, (rec["node_shear_min_deg"], rec["node_shear_max_deg"]), None, out)


def fe_levels(work: Path, solver: str, meshes: tuple[str, ...], ranks: int) -> list[Level]:
    sets = SETS + ((f"solver={solver}",) if solver == "explicit" else ())
    levels = []
    for row, _summary in study_runs("hemisphere", {"cells": meshes}, work / solver, sets,
                                    ranks, metrics=METRICS):
        if row.status != "completed":
            print(f"{solver} {row.values}: {row.status} ({row.reason})", file=sys.stderr)
            continue
        m = row.metrics
        levels.append(Level(f"macro {solver}, {row.values['cells'].replace(',', ' x ')}",
                            row.wall_s, row.unknowns, CellField.load(row.folder, SKIN),
                            (m["shear_min_deg_skin_top"], m["shear_max_deg_skin_top"]),
                            m["punch_force_max_N"], row.folder))
    return levels


def punch_distance(levels: list[Level], ref_level: Level) -> list[float]:
    """Median distance of the reference's top-skin cell centres from the punch, per band.

    The punch is a sphere (the case's ``punch_diameter``) whose tip is where the drape
    centred its net.
    """
    drape = next(lv for lv in levels if isinstance(lv.field, DrapeField))
    tip = np.array(json.loads((drape.folder / "drape.json").read_text())["net_centre_mm"])
    params = json.loads((ref_level.folder / "summary.json").read_text())["parameters"]
    radius = params["punch_diameter"] / 2
    ref = ref_level.field
    gap = np.linalg.norm(ref.x - (tip + [0.0, 0.0, radius]), axis=1) - radius
    r = np.hypot(ref.X[:, 0], ref.X[:, 1])
    return [float(np.median(gap[(r >= a) & (r < b)])) if np.any((r >= a) & (r < b))
            else float("nan") for a, b in zip(BANDS[:-1], BANDS[1:], strict=True)]


def differences(levels: list[Level], ref: CellField) -> list[dict]:
    """Each level against the reference at the reference's cell centres."""
    drape = next(lv.field for lv in levels if isinstance(lv.field, DrapeField))
    on_punch = np.isfinite(drape.at(ref.X))
    radius = np.hypot(ref.X[:, 0], ref.X[:, 1])
    rows = []
    for lv in levels:
        d = lv.field.at(ref.X) - ref.values
        whole, cover = rms(d, ref.volume)
        punch, _ = rms(np.where(on_punch, d, np.nan), ref.volume)
        bands = [rms(np.where((radius >= a) & (radius < b), d, np.nan), ref.volume)[0]
                 for a, b in zip(BANDS[:-1], BANDS[1:], strict=True)]
        rows.append({"level": lv, "rms_deg": whole, "cover": cover, "rms_punch_deg": punch,
                     "bands": bands, "d": d})
    return rows


def chart(rows: list[dict], ref_level: Level, path: Path, key: str = "rms_punch_deg",
          ylabels: tuple[str, str] = ("RMS shear difference on the punch [deg]",
                                      "punch force difference [%]"),
          title: str = "Hemisphere with skins and holder: each model against the implicit "
                       "20 x 20 x 4 run (dashed: the reference's wall time)") -> Path:
    """Each level's shear difference (``key``) and force difference against wall time."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    for k, r in enumerate(rows):
        lv = r["level"]
        if lv is ref_level:
            continue
        style = dict(marker="s" if lv.force_N is None else "o", ms=8, color=f"C{k}")
        axes[0].plot(lv.wall_s, r[key], **style)
        axes[0].annotate(lv.label, (lv.wall_s, r[key]), fontsize=8,
                         xytext=(5, 5), textcoords="offset points")
        if lv.force_N is not None:
            e = abs(lv.force_N / ref_level.force_N - 1) * 100
            axes[1].plot(lv.wall_s, e, **style)
            axes[1].annotate(lv.label, (lv.wall_s, e), fontsize=8, xytext=(5, 5),
                             textcoords="offset points")
    for ax, label in zip(axes, ylabels, strict=True):
        ax.axvline(ref_level.wall_s, color="k", ls="--", lw=1)
        ax.annotate(f"reference: {ref_level.label}", (ref_level.wall_s, 0.5),
                    xycoords=("data", "axes fraction"), rotation=90, fontsize=8,
                    ha="right", va="center")
        ax.set_ylabel(label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time [s] (2 cores)")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def level_cells(r: dict) -> str:
    """A table row's first cells: level, wall, unknowns, shear range, whole-skin RMS."""
    lv = r["level"]
    whole = f"{r['rms_deg']:.2f}" + (f" ({r['cover']:.0%} covered)" if r["cover"] < 0.999
                                     else "")
    return (f"| {lv.label} | {lv.wall_s:.1f} | {lv.unknowns or '-'} | "
            f"{lv.shear_range[0]:.1f} to {lv.shear_range[1]:.1f} | {whole} |")


def force_cells(lv: Level, ref_force: float, unit: float = 1.0, fmt: str = ".0f") -> str:
    """A table row's last cells: the level's force (in ``unit``) and its difference."""
    if lv.force_N is None:
        return " - | - |"
    return f" {lv.force_N / unit:{fmt}} | {lv.force_N / ref_force - 1:+.1%} |"


def maps(rows: list[dict], ref: CellField, path: Path) -> Path:
    import matplotlib.pyplot as plt

    xs, ys = np.unique(np.round(ref.X[:, 0], 6)), np.unique(np.round(ref.X[:, 1], 6))
    ix, iy = np.searchsorted(xs, np.round(ref.X[:, 0], 6)), np.searchsorted(ys, np.round(
        ref.X[:, 1], 6))
    hx, hy = xs[1] - xs[0], ys[1] - ys[0]
    ex = np.append(xs - hx / 2, xs[-1] + hx / 2)
    ey = np.append(ys - hy / 2, ys[-1] + hy / 2)
    fig, axes = plt.subplots(1, len(rows), figsize=(3.3 * len(rows), 3.8),
                             layout="constrained", squeeze=False)
    for ax, r in zip(axes[0], rows, strict=True):
        grid = np.full((xs.size, ys.size), np.nan)
        grid[ix, iy] = r["d"] + ref.values
        pc = ax.pcolormesh(ex, ey, grid.T, cmap="coolwarm", vmin=-50, vmax=50)
        ax.set_aspect("equal")
        ax.set_title(r["level"].label, fontsize=8)
        ax.set_xlabel("X [mm]")
    axes[0][0].set_ylabel("Y [mm] (flat blank)")
    fig.colorbar(pc, ax=axes[0].tolist(), shrink=0.8, label="top skin shear [deg]")
    fig.suptitle("Top skin shear at the end of the stroke, by material point (quarter of the "
                 "flat blank; on the reference's cells; blank: not covered)", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def verdict(rows: list[dict], gaps: list[float], ref_level: Level) -> list[str]:
    """Where the drape stops being good enough, and what the other rungs show."""
    drape = next(r for r in rows if isinstance(r["level"].field, DrapeField))
    fe = [r for r in rows if r["level"].force_N is not None and r["level"] is not ref_level]
    good = 0
    while good < len(drape["bands"]) and drape["bands"][good] <= 1.0:
        good += 1
    worst_fe = max(max(b for b in r["bands"] if np.isfinite(b)) for r in fe)
    out = [f"- **Kinematic drape.** Within 1 deg RMS of the reference up to {BANDS[good]:.0f} "
           f"mm from the pole ({', '.join(f'{b:.2f}' for b in drape['bands'][:good])} deg), "
           "where the top skin lies on the punch (the reference's median distance from it: "
           f"{', '.join(f'{g:.2f}' for g in gaps[:good])} mm; centroids of flat cells on a "
           "curved surface sit a sagitta inside it). Beyond, the sandwich leaves the punch "
           f"for the die radius (median distance {gaps[good]:.1f} mm, then "
           f"{gaps[good + 1]:.1f} mm) while the drape wraps the punch to its equator: it is "
           f"off by {drape['bands'][good]:.1f} and {drape['bands'][good + 1]:.1f} deg RMS "
           "there. A drape knows neither the core's bending stiffness nor the die and "
           "holder, which decide where the fabric stops following the punch.",
           f"- **Finite-element levels.** Every macro level stays within {worst_fe:.1f} deg RMS "
           "of the reference in every band."]
    for r in fe:
        lv = r["level"]
        twin = next((t for t in fe if t["level"].label == lv.label.replace("explicit",
                                                                            "implicit")), None)
        if "explicit" in lv.label and twin is not None:
            same = lv.force_N / twin["level"].force_N - 1
            out.append(f"- **Explicit.** Against the implicit run on the same mesh: shear "
                       f"{r['rms_punch_deg']:.2f} against {twin['rms_punch_deg']:.2f} deg RMS "
                       f"from the reference on the punch, {r['rms_deg']:.2f} against "
                       f"{twin['rms_deg']:.2f} over the whole skin; punch force {same:+.1%} "
                       f"from the implicit one ({lv.force_N:.0f} against "
                       f"{twin['level'].force_N:.0f} N), so its "
                       f"{lv.force_N / ref_level.force_N - 1:+.0%} from the reference is "
                       "mostly the coarser mesh's (`forming compare` of this scene: "
                       "docs/validation.md).")
    return out


def markdown(rows: list[dict], ref_level: Level, gaps: list[float], ranks: int) -> str:
    ref_f = ref_level.force_N
    lines = [
        "## The fidelity ladder: from a kinematic drape to the finite-element models "
        "(issue 19)", "",
        "`python benchmarks/fidelity_ladder.py --write`: `hemisphere --set skins=true --set "
        f"blank_holder=true`, each finite-element run on {ranks} ranks, one at a time; "
        f"{machine()}.",
        "Reference: the implicit run on the default mesh (20 x 20 x 4). Shear differences are "
        "taken material point by material point at the reference's top-skin cell centres "
        "(`forming.post.skinfield`), volume-weighted; \"on the punch\" is the part of the "
        "skin the drape covers. Wall: the drape's whole command as a process (one process); "
        "a finite-element run's `timing.wall_s` (mesh generation included, interpreter start "
        "not). The drape's shear range is over its whole net, which wraps the punch to its "
        "equator.", "",
        "| level | wall [s] | unknowns | top skin shear [deg] | RMS diff. whole skin [deg] "
        "| RMS diff. on the punch [deg] | punch force [N] | force diff. |",
        "|---|---:|---:|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"{level_cells(r)} {r['rms_punch_deg']:.2f} |"
                     f"{force_cells(r['level'], ref_f)}")
    lines += ["| meso (cell walls) | not yet: issue 20 | | | | | | |", "",
              "RMS shear difference to the reference by distance from the pole in the flat "
              "blank [deg] (the punch's pole-to-equator arc is 78.5 mm):", "",
              "| level | " + " | ".join(f"{a:.0f}-{b:.0f} mm" for a, b in
                                        zip(BANDS[:-1], BANDS[1:], strict=True)) + " |",
              "|---|" + "---:|" * (len(BANDS) - 1)]
    for r in rows:
        if r["level"] is ref_level:
            continue
        lines.append(f"| {r['level'].label} | " + " | ".join(
            "-" if not np.isfinite(b) else f"{b:.2f}" for b in r["bands"]) + " |")
    lines.append("| reference top skin: median distance from the punch [mm] | "
                 + " | ".join(f"{g:.2f}" for g in gaps) + " |")
    lines += ["", *verdict(rows, gaps, ref_level)]
    lines += ["", "![fidelity ladder](figures/fidelity_ladder.png)", "",
              "![shear maps](figures/fidelity_ladder_maps.png)"]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=REPO / "results" / "fidelity_ladder")
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--write", action="store_true", help="update docs/performance.md")
    args = parser.parse_args()
    levels = [drape_level(args.work),
              *fe_levels(args.work, "implicit", IMPLICIT, args.ranks),
              *fe_levels(args.work, "explicit", EXPLICIT, args.ranks)]
    ref_level = next((lv for lv in levels if lv.label.startswith("macro implicit")
                      and lv.label.endswith(IMPLICIT[-1].replace(",", " x "))), None)
    if ref_level is None:
        sys.exit("the reference run (implicit, 20 x 20 x 4) did not complete")
    rows = differences(levels, ref_level.field)
    FIG.mkdir(parents=True, exist_ok=True)
    chart(rows, ref_level, FIG / "fidelity_ladder.png")
    maps(rows, ref_level.field, FIG / "fidelity_ladder_maps.png")
    text = markdown(rows, ref_level, punch_distance(levels, ref_level), args.ranks)
    print(text)
    if args.write:
        update_section("fidelity_ladder", text)


if __name__ == "__main__":
    main()
