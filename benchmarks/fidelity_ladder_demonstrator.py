"""The fidelity ladder of the demonstrator: a kinematic drape against the sandwich model.

``demonstrator`` with its defaults (issue 18), from the cheapest model to the dearest:

1. the kinematic drape onto the lower tool (``forming drape demonstrator --tool lower``,
   its default net spacing), timed as a process: the bottom skin's shear as a
   pin-jointed net would have it;
2. the macro model, implicit, at element sizes 60 and 45 mm and the default 30 mm (the
   reference, the finest finite-element result);
3. the macro model, explicit, at 60 mm (compared also with the implicit run on the same
   mesh);
4. the meso model: not yet (issue 20).

The finite-element runs are ``forming study`` runs on 2 ranks each, one at a time, in
``--work`` (``results/fidelity_ladder_demonstrator``): a rerun reuses what is there. For
every level: wall time, the bottom skin's shear range, the RMS difference of its shear
field to the reference's (material point by material point at the reference's cell
centres, :mod:`forming.post.skinfield`), over the whole skin, on the flange and in the
dish (where the reference's bottom skin ends above or below 1 mm under the flange), and
the closing force's difference. Writes docs/figures/fidelity_ladder_demonstrator.png
(difference against wall time), fidelity_ladder_demonstrator_maps.png (the shear fields)
and, with ``--write``, the ``fidelity_ladder_demonstrator`` section of
docs/performance.md.

Run alone (wall times): ``python benchmarks/fidelity_ladder_demonstrator.py --write``
(about 15 minutes on 2 cores from nothing; seconds when the runs are in ``--work``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from _report import REPO, machine, study_runs, update_section
from fidelity_ladder import Level, chart, drape_level, force_cells, level_cells

sys.path.insert(0, str(REPO))
from forming.post.skinfield import CellField, DrapeField, rms  # noqa: E402

SIZES = ("60", "45", "30")  # element sizes [mm]; the last is the reference
EXPLICIT = ("60",)  # element sizes of the explicit level
SKIN = "skin_bottom"  # the skin on the lower tool (the drape's surface)
METRICS = ("closing_force_max_N", f"shear_min_deg_{SKIN}", f"shear_max_deg_{SKIN}")
FLANGE = -1.0  # a reference cell whose formed centroid ends above this z is on the flange
FIG = REPO / "docs" / "figures"


def fe_levels(work: Path, solver: str, sizes: tuple[str, ...], ranks: int) -> list[Level]:
    # the settings the ladder was measured with, the case's defaults until 2026-11-29:
    # explicit over 0.05 s; implicit with slip 5e-3 and one solve per step
    sets = (("solver=explicit", "explicit.loading_time=0.05") if solver == "explicit" else
            ("skin_elastic_slip=5e-3", "newton.spring_release=1"))
    levels = []
    for row, _summary in study_runs("demonstrator", {"element_size": sizes}, work / solver,
                                    sets, ranks, metrics=METRICS):
        if row.status != "completed":
            print(f"{solver} {row.values}: {row.status} ({row.reason})", file=sys.stderr)
            continue
        m = row.metrics
        levels.append(Level(f"macro {solver}, {row.values['element_size']} mm", row.wall_s,
                            row.unknowns, CellField.load(row.folder, SKIN),
                            (m[f"shear_min_deg_{SKIN}"], m[f"shear_max_deg_{SKIN}"]),
                            m["closing_force_max_N"], row.folder))
    return levels


def differences(levels: list[Level], ref: CellField) -> list[dict]:
    """Each level against the reference at the reference's cell centres."""
    flange = ref.x[:, 2] > FLANGE
    rows = []
    for lv in levels:
        values = lv.field.at(ref.X)
        d = values - ref.values
        whole, cover = rms(d, ref.volume)
        rows.append({"level": lv, "values": values, "rms_deg": whole, "cover": cover,
                     "flange_deg": rms(np.where(flange, d, np.nan), ref.volume)[0],
                     "dish_deg": rms(np.where(flange, np.nan, d), ref.volume)[0],
                     "peak_deg": float(np.nanmax(np.abs(values))),
                     "correlation": _correlation(values, ref.values, ref.volume)})
    return rows


def _correlation(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> float:
    """Volume-weighted Pearson correlation of two fields where both are defined."""
    ok = np.isfinite(a) & np.isfinite(b)
    a, b, w = a[ok], b[ok], w[ok] / w[ok].sum()
    da, db = a - np.sum(w * a), b - np.sum(w * b)
    return float(np.sum(w * da * db) / np.sqrt(np.sum(w * da**2) * np.sum(w * db**2)))


def maps(rows: list[dict], ref: CellField, path: Path) -> Path:
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    tri = Triangulation(ref.X[:, 0], ref.X[:, 1])
    fig, axes = plt.subplots(1, len(rows), figsize=(3.4 * len(rows), 3.6),
                             layout="constrained", squeeze=False)
    for ax, r in zip(axes[0], rows, strict=True):
        v = np.ma.masked_invalid(r["values"])
        pc = ax.tripcolor(tri, v, shading="gouraud", cmap="coolwarm", vmin=-40, vmax=40)
        ax.set_aspect("equal")
        ax.set_title(r["level"].label, fontsize=8)
        ax.set_xlabel("X [mm]")
    axes[0][0].set_ylabel("Y [mm] (flat blank)")
    fig.colorbar(pc, ax=axes[0].tolist(), shrink=0.8, label="bottom skin shear [deg]")
    fig.suptitle("Bottom skin shear by material point (quarter of the flat blank, at the "
                 "reference's cell centres; hatched: not covered)", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def verdict(rows: list[dict], ref_level: Level) -> list[str]:
    """What the ladder says, from its numbers."""
    drape = next(r for r in rows if isinstance(r["level"].field, DrapeField))
    fe = [r for r in rows if r["level"].force_N is not None and r["level"] is not ref_level
          and "implicit" in r["level"].label]
    explicit = [r for r in rows if "explicit" in r["level"].label]
    ref = next(r for r in rows if r["level"] is ref_level)
    out = [f"- **Kinematic drape.** {drape['rms_deg']:.1f} deg RMS from the reference over "
           f"the bottom skin it covers ({drape['flange_deg']:.1f} on the flange, "
           f"{drape['dish_deg']:.1f} in the dish); its largest shear at the reference's points "
           f"is {drape['peak_deg']:.0f} deg against the reference's {ref['peak_deg']:.0f} "
           f"(a factor {drape['peak_deg'] / ref['peak_deg']:.1f}), and the two fields "
           f"correlate with r = {drape['correlation']:.2f}. The pin-jointed net follows the "
           "dish freely and carries the shear of the dish's ends out along its fibres onto "
           "the flange; the sandwich's skin is pressed onto a core with friction and "
           "shears far less. On this part the drape points only loosely at where the "
           "shear gathers and overstates how much: it knows neither the core nor the "
           "friction." + (" Every coarser finite-element level is closer to the "
                          "reference, on the flange and in the dish."
                          if all(r[k] < drape[k] for r in fe
                                 for k in ("rms_deg", "flange_deg", "dish_deg")) else "")]
    forces = [r["level"].force_N for r in fe] + [ref_level.force_N]
    steps = ", ".join(f"{b / a - 1:+.1%}" for a, b in zip(forces[:-1], forces[1:], strict=True))
    out.append(f"- **Mesh convergence.** From level to level the closing force changes by "
               f"{steps}: it does not settle yet, so `forming study` extrapolates nothing "
               "(`results/fidelity_ladder_demonstrator/implicit/study.md`). The default "
               "mesh's force is uncertain at the percent level, and its bottom skin's shear "
               f"field moved by {fe[-1]['rms_deg']:.1f} deg RMS from the next coarser level.")
    for r in fe:
        lv = r["level"]
        out.append(f"- **{lv.label}.** {r['rms_deg']:.2f} deg RMS from the reference "
                   f"({r['flange_deg']:.2f} on the flange, {r['dish_deg']:.2f} in the dish), "
                   f"closing force {lv.force_N / ref_level.force_N - 1:+.1%}, in "
                   f"{lv.wall_s / ref_level.wall_s:.0%} of the reference's wall time.")
    for r in explicit:
        lv = r["level"]
        twin = next((t for t in fe if t["level"].label == lv.label.replace("explicit",
                                                                            "implicit")), None)
        if twin is None:
            continue
        tw = twin["level"]
        out.append(f"- **{lv.label}.** Against the implicit run on the same mesh: "
                   f"{r['rms_deg']:.2f} against {twin['rms_deg']:.2f} deg RMS from the "
                   f"reference, closing force {lv.force_N / tw.force_N - 1:+.1%} from the "
                   f"implicit one ({lv.force_N / 1e3:.1f} against {tw.force_N / 1e3:.1f} kN), "
                   f"in {lv.wall_s / tw.wall_s:.2f} times its wall time (`forming compare "
                   "demonstrator`: docs/validation.md, \"The demonstrator\").")
    return out


def markdown(rows: list[dict], ref_level: Level, ranks: int) -> str:
    ref_f = ref_level.force_N
    lines = [
        "## The fidelity ladder of the demonstrator (issues 18, 19)", "",
        "`python benchmarks/fidelity_ladder_demonstrator.py --write`: `demonstrator` with "
        f"its defaults, each finite-element run on {ranks} ranks, one at a time; "
        f"{machine()}.",
        "Reference: the implicit run at the default element size (30 mm). Shear differences "
        "of the bottom skin (the one on the lower tool, which the drape covers) are taken "
        "material point by material point at the reference's cell centres "
        "(`forming.post.skinfield`, linear between the scattered centres of the "
        "unstructured skin meshes), volume-weighted; \"flange\" is where the reference's "
        f"bottom skin ends above z = {FLANGE:g} mm, \"dish\" the rest. Wall: the drape's "
        "whole command as a process; a finite-element run's `timing.wall_s`.", "",
        "| level | wall [s] | unknowns | bottom skin shear [deg] | RMS diff. [deg] "
        "| flange [deg] | dish [deg] | closing force [kN] | force diff. |",
        "|---|---:|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"{level_cells(r)} {r['flange_deg']:.2f} | {r['dish_deg']:.2f} |"
                     f"{force_cells(r['level'], ref_f, 1e3, '.1f')}")
    lines += ["| meso (cell walls) | not yet: issue 20 | | | | | | | |", "",
              *verdict(rows, ref_level), "",
              "![demonstrator ladder](figures/fidelity_ladder_demonstrator.png)", "",
              "![demonstrator shear maps](figures/fidelity_ladder_demonstrator_maps.png)"]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path,
                        default=REPO / "results" / "fidelity_ladder_demonstrator")
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--write", action="store_true", help="update docs/performance.md")
    args = parser.parse_args()
    levels = [drape_level(args.work, "demonstrator", ("--tool", "lower")),
              *fe_levels(args.work, "implicit", SIZES, args.ranks),
              *fe_levels(args.work, "explicit", EXPLICIT, args.ranks)]
    ref_level = next((lv for lv in levels if lv.label == f"macro implicit, {SIZES[-1]} mm"),
                     None)
    if ref_level is None:
        sys.exit(f"the reference run (implicit, {SIZES[-1]} mm) did not complete")
    rows = differences(levels, ref_level.field)
    FIG.mkdir(parents=True, exist_ok=True)
    chart(rows, ref_level, FIG / "fidelity_ladder_demonstrator.png", "rms_deg",
          ("RMS bottom-skin shear difference [deg]", "closing force difference [%]"),
          "Demonstrator: each model against the implicit run at 30 mm (dashed: the "
          "reference's wall time)")
    maps(rows, ref_level.field, FIG / "fidelity_ladder_demonstrator_maps.png")
    text = markdown(rows, ref_level, args.ranks)
    print(text)
    if args.write:
        update_section("fidelity_ladder_demonstrator", text)


if __name__ == "__main__":
    main()
