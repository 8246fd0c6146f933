"""Cross-check of a case: the same scene run with the implicit and the explicit solver.

``forming compare CASE`` runs ``CASE`` twice, into ``<out>/implicit`` and
``<out>/explicit``, and compares what came out:

- the force-travel curves (the job's :class:`~forming.run.Response`) on one plot, with the
  RMS difference over the stroke and the difference in peak and final force, all relative
  to the implicit peak force;
- the final deformed shapes: the nodal distance between the two final configurations
  (max and RMS, relative to the core thickness);
- every scalar metric both runs report (crushed volume, shear-angle range, ...);
- the explicit run's energy balance and kinetic/internal energy ratio;
- the wall time of each.

It writes ``report.md`` with PNGs and ``compare.json`` into ``<out>``. The explicit tool
forces are means over each output interval (docs/theory.md, section 12), so the implicit
force is averaged over the same intervals before the two are compared.
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from forming.errors import InputError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Targets:
    """Acceptance limits of the cross-check (issue #5, item 4).

    Attributes:
        force_rms: Force-travel RMS difference relative to the peak force.
        shape_rms: RMS nodal distance relative to the core thickness.
        energy_balance: Explicit energy-balance error relative to the external work.
    """

    force_rms: float = 0.03
    shape_rms: float = 0.02
    energy_balance: float = 0.01


@dataclass(frozen=True)
class RunResult:
    """What one solver's run left on disk."""

    summary: dict
    history: dict[str, np.ndarray]
    shape: dict[str, np.ndarray]

    @classmethod
    def load(cls, folder: Path) -> RunResult:
        """Read ``summary.json``, ``history.csv`` and ``final_shape.npz`` of a run."""
        summary = json.loads((folder / "summary.json").read_text())
        data = np.genfromtxt(folder / "history.csv", delimiter=",", names=True)
        history = {k: np.atleast_1d(data[k]).astype(float) for k in data.dtype.names}
        with np.load(folder / "final_shape.npz") as z:
            shape = {k: z[k] for k in z.files}
        return cls(summary, history, shape)


def interval_means(s_imp: np.ndarray, f_imp: np.ndarray, s_edges: np.ndarray,
                   options, samples: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Time means of the load parameter and of the implicit force over explicit intervals.

    The explicit solver writes the mean force over each output interval (in time). The
    implicit force, a function of the load parameter s, is averaged the same way: over
    the time of each interval, with s following the explicit load programme ``options``
    (:class:`~forming.solver.explicit.ExplicitOptions`), so that both curves carry the
    same filter. The first entry (s = 0) is kept as it is.

    Returns:
        The mean load parameter and the mean implicit force of every interval.
    """
    s_mean, f_mean = [float(s_edges[0])], [float(np.interp(s_edges[0], s_imp, f_imp))]
    for a, b in zip(s_edges[:-1], s_edges[1:], strict=True):
        tau = np.linspace(options.time_of(a), options.time_of(b), samples)
        s = np.array([options.load(x) for x in tau])
        span = tau[-1] - tau[0]
        if span <= 0:
            s_mean.append(float(b))
            f_mean.append(float(np.interp(b, s_imp, f_imp)))
            continue
        s_mean.append(float(np.trapezoid(s, tau) / span))
        f_mean.append(float(np.trapezoid(np.interp(s, s_imp, f_imp), tau) / span))
    return np.array(s_mean), np.array(f_mean)


def _force_curves(response, imp: RunResult, exp: RunResult, options):
    """Implicit and explicit (travel, force), and the implicit force filtered alike.

    The filtered implicit force is its time mean over each explicit output interval.
    """
    for run, name in ((imp, "implicit"), (exp, "explicit")):
        if response.column not in run.history:
            raise InputError("response.column",
                             f"{response.column!r} is not in the {name} run's history.csv")
    xi, fi = response.curve(imp.history["t"], imp.history[response.column])
    s_mean, f_filtered = interval_means(imp.history["t"], imp.history[response.column],
                                        exp.history["t"], options)
    xe, fe = response.curve(s_mean, exp.history[response.column])
    _x, fi_on_exp = response.curve(s_mean, f_filtered)
    return (xi, fi), (xe, fe), fi_on_exp


def force_differences(imp_curve, exp_curve, imp_on_exp: np.ndarray | None = None
                      ) -> dict[str, float]:
    """RMS, peak and final force differences relative to the implicit peak |force|.

    The differences are taken at the explicit points: against ``imp_on_exp`` (the
    implicit force filtered like the explicit one, :func:`interval_means`) when given,
    else against the implicit curve interpolated linearly there. An explicit force is a
    mean over an output interval, so a peak at the end of the stroke is compared with the
    implicit force filtered the same way, not with its end value. The implicit peak
    reported (``peak_force_implicit_N``) is that of its own steps.
    """
    (xi, fi), (xe, fe) = imp_curve, exp_curve
    peak = float(np.max(np.abs(fi)))
    if peak == 0:
        raise InputError("response", "the implicit force is zero throughout")
    inside = (xe >= xi.min() - 1e-12) & (xe <= xi.max() + 1e-12)
    xe, fe = xe[inside], fe[inside]
    fi_at = np.interp(xe, xi, fi) if imp_on_exp is None else np.asarray(imp_on_exp)[inside]
    diff = fe - fi_at
    i_peak, e_peak = fi[np.argmax(np.abs(fi))], fe[np.argmax(np.abs(fe))]
    i_peak_at = fi_at[np.argmax(np.abs(fi_at))]
    return {
        "force_rms_diff_rel": float(np.sqrt(np.mean(diff**2)) / peak),
        "force_max_diff_rel": float(np.max(np.abs(diff)) / peak),
        "peak_force_implicit_N": float(i_peak),
        "peak_force_explicit_N": float(e_peak),
        "peak_force_diff_rel": float((e_peak - i_peak_at) / abs(i_peak_at)),
        "final_force_implicit_N": float(fi[-1]),
        "final_force_explicit_N": float(fe[-1]),
        "final_force_diff_rel": float((fe[-1] - fi_at[-1]) / peak),
    }


def reference_thickness(shape: dict[str, np.ndarray]) -> float:
    """The core's z extent (or the first body's) in the reference configuration [mm]."""
    names = sorted(k[:-2] for k in shape if k.endswith("_X"))
    name = "core" if "core" in names else names[0]
    z = shape[f"{name}_X"][:, 2]
    return float(z.max() - z.min())


def shape_differences(imp: dict[str, np.ndarray], exp: dict[str, np.ndarray],
                      thickness: float) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """Nodal distances between the final shapes, per body and over all bodies.

    The distance is split into its part along z (the tools' closing direction: where the
    formed surface lies) and its part in plan (where the material points lie on it: a skin
    that slid farther on a flat flange has moved in plan without changing the part's form).

    Returns:
        The figures (``shape_rms_diff_rel_thickness``, ``shape_max_diff_rel_thickness``,
        ``shape_rms_diff_mm_z`` and ``shape_rms_diff_mm_plan``, and per body
        ``shape_rms_diff_mm_<body>``), and each body's distances [mm].
    """
    dist: dict[str, np.ndarray] = {}
    along_z: list[np.ndarray] = []
    in_plan: list[np.ndarray] = []
    # a body's nodes are "<body>_X" with "<body>_u"; a fabric's cell field
    # ("<body>_cell_X", "_x", ...) is not a body
    for key in sorted(k for k in imp if k.endswith("_X") and f"{k[:-2]}_u" in imp):
        name = key[:-2]
        if key not in exp or exp[key].shape != imp[key].shape or not np.allclose(
                exp[key], imp[key], atol=1e-6):
            raise InputError("mesh", f"body {name!r}: the two runs have different meshes")
        du = exp[f"{name}_u"] - imp[f"{name}_u"]
        dist[name] = np.linalg.norm(du, axis=1)
        along_z.append(du[:, 2])
        in_plan.append(np.linalg.norm(du[:, :2], axis=1))
    every, z = np.concatenate(list(dist.values())), np.concatenate(along_z)
    plan = np.concatenate(in_plan)
    figures = {
        "thickness_mm": thickness,
        "shape_rms_diff_mm": float(np.sqrt(np.mean(every**2))),
        "shape_max_diff_mm": float(every.max()),
        "shape_rms_diff_rel_thickness": float(np.sqrt(np.mean(every**2)) / thickness),
        "shape_max_diff_rel_thickness": float(every.max() / thickness),
        "shape_rms_diff_mm_z": float(np.sqrt(np.mean(z**2))),
        "shape_rms_diff_mm_plan": float(np.sqrt(np.mean(plan**2))),
    }
    if len(dist) > 1:
        figures |= {f"shape_rms_diff_mm_{n}": float(np.sqrt(np.mean(d**2)))
                    for n, d in dist.items()}
    return figures, dist


def _shared_metrics(imp: dict, exp: dict) -> list[tuple[str, float, float]]:
    """Scalar metrics reported by both runs (booleans and solver figures left out)."""
    solver_keys = {"kinetic_to_internal_max", "quasi_static", "mass_added_fraction",
                   "energy_balance_error_rel"}
    rows = []
    for k, v in imp.items():
        w = exp.get(k)
        if k in solver_keys or isinstance(v, bool) or isinstance(w, bool):
            continue
        if isinstance(v, int | float) and isinstance(w, int | float):
            rows.append((k, float(v), float(w)))
    return rows


def _plots(out: Path, response, curves, exp: RunResult, dist: dict, shape: dict,
           case: str) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from forming.output import plot_curves

    (xi, fi), (xe, fe), fi_on_exp = curves
    paths = [plot_curves(out / "force_travel.png",
                         [(xi, fi, "implicit", "o-"),
                          (xe, fi_on_exp, "implicit, interval means", "+"),
                          (xe, fe, "explicit (interval means)", "s--")],
                         "travel [mm]", f"{response.label} [N]", f"{case}: implicit vs explicit")]
    h = exp.history
    if "energy_internal_Nmm" in h:
        series = [(h["t"], h[k], lbl, sty) for k, lbl, sty in (
            ("work_external_Nmm", "external work", "k-"),
            ("energy_internal_Nmm", "internal", "b-"),
            ("energy_friction_Nmm", "friction", "g-"),
            ("energy_kinetic_Nmm", "kinetic", "r-"),
            ("energy_balance_Nmm", "balance (error)", "m:"))]
        paths.append(plot_curves(out / "explicit_energies.png", series, "load parameter",
                                 "energy [N mm]", f"{case}: explicit energies"))
    # where the final shapes differ: each body's nodes in plan view (one panel a body: the
    # skins lie over the core), coloured by the largest distance through the thickness
    n = len(dist)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n + 1.2, 4.6), dpi=120, squeeze=False,
                             sharey=True, layout="constrained")
    vmax = max(float(d.max()) for d in dist.values()) or 1.0
    for ax, (name, d) in zip(axes[0], dist.items(), strict=True):
        xy, col = np.unique(np.round(shape[f"{name}_X"][:, :2], 6), axis=0,
                            return_inverse=True)
        dmax = np.zeros(len(xy))
        np.maximum.at(dmax, col.ravel(), d)
        sc = ax.scatter(xy[:, 0], xy[:, 1], c=dmax, s=18, vmin=0.0, vmax=vmax,
                        cmap="viridis")
        ax.set_title(f"{name}: RMS {np.sqrt(np.mean(d**2)):.3g} mm", fontsize=10)
        ax.set_xlabel("x [mm]")
        ax.set_aspect("equal")
    axes[0][0].set_ylabel("y [mm]")
    fig.colorbar(sc, ax=axes[0].tolist(), label="|u_explicit - u_implicit| [mm]")
    fig.suptitle(f"{case}: final shape difference (largest through the thickness)")
    fig.savefig(out / "shape_difference.png")
    plt.close(fig)
    paths.append(out / "shape_difference.png")
    return paths


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if v == 0 or not math.isfinite(v):
            return str(v)
        return f"{v:.4g}"
    return str(v)


def _checks(validity: dict) -> str:
    """The failed checks of both runs, or "all pass"."""
    failed = [f"{run}: {name}" for run, checks in validity.items()
              for name, ok in checks.items() if not ok]
    return "failed: " + "; ".join(failed) if failed else "all pass"


def _report(out: Path, case: str, result: dict, shared, pngs: list[Path],
            assignments: list[str]) -> Path:
    r, tg = result, result["targets"]
    command = " ".join(["forming compare", case] + [f"--set {a}" for a in assignments])
    lines = [
        f"# {case}: implicit against explicit", "",
        f"Command: `{command}`. Runs in `implicit/` and `explicit/`.", "",
        "| quantity | value | target | met |", "|---|---|---|---|",
        f"| force RMS difference / peak | {r['force_rms_diff_rel']:.2%} | "
        f"{tg['force_rms']:.0%} | {_fmt(r['force_rms_diff_rel'] <= tg['force_rms'])} |",
        f"| final shape RMS distance / thickness ({r['thickness_mm']:.4g} mm) | "
        f"{r['shape_rms_diff_rel_thickness']:.2%} | {tg['shape_rms']:.0%} | "
        f"{_fmt(r['shape_rms_diff_rel_thickness'] <= tg['shape_rms'])} |",
        f"| explicit energy balance error / external work | "
        f"{r['energy_balance_error_rel']:.2%} | {tg['energy_balance']:.0%} | "
        f"{_fmt(r['energy_balance_error_rel'] <= tg['energy_balance'])} |",
        f"| explicit quasi-static (KE/IE max {r['kinetic_to_internal_max']:.2%}) | "
        f"{_fmt(r['explicit_quasi_static'])} | yes | {_fmt(r['explicit_quasi_static'])} |",
        f"| each run's own checks ({_checks(r['validity'])}) | implicit "
        f"{_fmt(r['valid_implicit'])}, explicit {_fmt(r['valid_explicit'])} | yes | "
        f"{_fmt(r['valid_implicit'] and r['valid_explicit'])} |",
        "", "| | implicit | explicit | difference |", "|---|---|---|---|",
        f"| status | {r['status_implicit']} | {r['status_explicit']} | |",
        f"| peak force [N] | {r['peak_force_implicit_N']:.5g} | {r['peak_force_explicit_N']:.5g}"
        f" | {r['peak_force_diff_rel']:+.2%} (interval means) |",
        f"| final force [N] | {r['final_force_implicit_N']:.5g} | "
        f"{r['final_force_explicit_N']:.5g} | {r['final_force_diff_rel']:+.2%} of peak "
        "(last interval's means) |",
        f"| final shape: max nodal distance [mm] | | | {r['shape_max_diff_mm']:.4g} "
        f"({r['shape_max_diff_rel_thickness']:.2%} of thickness) |",
        f"| final shape: RMS distance along z / in plan [mm] | | | "
        f"{r['shape_rms_diff_mm_z']:.3g} / {r['shape_rms_diff_mm_plan']:.3g} |",
        f"| wall time [s] | {r['wall_s_implicit']:.1f} | {r['wall_s_explicit']:.1f} | "
        f"x{r['wall_s_explicit'] / r['wall_s_implicit']:.2f} |",
        f"| steps / time increments | {r['steps_implicit']} | {r['time_steps_explicit']} | |",
        f"| mass added (explicit) | | {r['mass_added_fraction']:.2%} | |",
    ]
    lines += [f"| final shape: RMS distance, {k.removeprefix('shape_rms_diff_mm_')} [mm] | | | "
              f"{r[k]:.3g} |" for k in sorted(r) if k.startswith("shape_rms_diff_mm_")
              and k not in ("shape_rms_diff_mm_z", "shape_rms_diff_mm_plan")]
    for k, v, w in shared:
        rel = f"{(w - v) / abs(v):+.2%}" if v != 0 else ""
        lines.append(f"| {k} | {_fmt(v)} | {_fmt(w)} | {rel} |")
    lines += ["", "The explicit forces are means over each output interval (in time); the "
              "implicit curve is averaged over the same intervals (along the explicit load "
              "programme) before the differences are taken, and both are plotted at the "
              "intervals' mean travel.", ""]
    lines += [f"![{p.stem}]({p.name})" for p in pngs]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def compare(case: str, out: Path, assignments: list[str], targets: Targets = Targets(),
            build=None, params_cls=None, reuse: bool = False) -> dict:
    """Run ``case`` with both solvers into ``out`` and write the cross-check report.

    ``assignments`` (``--set key=value``) apply to both runs; ``explicit.*`` settings
    only affect the explicit one. ``solver=...`` is not allowed here. With ``reuse`` the
    runs already in ``out/implicit`` and ``out/explicit`` are compared again (same
    settings), without running anything.

    Returns:
        The figures written to ``compare.json``.
    """
    from mpi4py import MPI

    from forming.case import prepare_case, split_solver_settings
    from forming.run import simulate

    if split_solver_settings(assignments)[0]:
        raise InputError("--set solver", "forming compare runs both solvers; drop it")
    # one job (one mesh) for both runs: the solver is the only difference
    job, params = prepare_case(case, assignments, build, params_cls)
    response = job.response_or_default()
    out = Path(out)
    for solver in ("implicit", "explicit"):
        if reuse:
            if not (out / solver / "summary.json").is_file():
                raise InputError("--reuse", f"no finished run in {out / solver}")
            continue
        log.info("compare %s: %s run", case, solver)
        run = replace(job, solver=solver)
        simulate(run, out / solver, case, params)
    comm = MPI.COMM_WORLD
    result: dict = {}
    if comm.rank == 0:
        imp, exp = RunResult.load(out / "implicit"), RunResult.load(out / "explicit")
        curves = _force_curves(response, imp, exp, job.explicit)
        thickness = reference_thickness(imp.shape)
        shape_fig, dist = shape_differences(imp.shape, exp.shape, thickness)
        em = exp.summary["metrics"]
        result = {
            "case": case,
            "status_implicit": imp.summary["status"],
            "status_explicit": exp.summary["status"],
            "response": {"column": response.column, "travel_mm": response.travel,
                         "scale": response.scale},
            **force_differences(*curves),
            "force_filter": "time means over the explicit output intervals",
            **shape_fig,
            "wall_s_implicit": imp.summary["timing"]["wall_s"],
            "wall_s_explicit": exp.summary["timing"]["wall_s"],
            "steps_implicit": imp.summary["timing"]["steps"],
            "newton_iterations_implicit": imp.summary["timing"]["work"],
            "time_steps_explicit": exp.summary["timing"]["work"],
            "explicit_quasi_static": bool(em.get("quasi_static", False)),
            "kinetic_to_internal_max": em.get("kinetic_to_internal_max", float("nan")),
            "energy_balance_error_rel": em.get("energy_balance_error_rel", float("nan")),
            "mass_added_fraction": em.get("mass_added_fraction", 0.0),
            "targets": {"force_rms": targets.force_rms, "shape_rms": targets.shape_rms,
                        "energy_balance": targets.energy_balance},
        }
        shared = _shared_metrics(imp.summary["metrics"], em)
        result["metrics"] = {k: {"implicit": v, "explicit": w} for k, v, w in shared}
        result["valid_implicit"] = bool(imp.summary.get("valid", True))
        result["valid_explicit"] = bool(exp.summary.get("valid", True))
        result["validity"] = {"implicit": imp.summary.get("validity", {}),
                              "explicit": exp.summary.get("validity", {})}
        result["meets_targets"] = bool(
            result["status_implicit"] == result["status_explicit"] == "completed"
            and result["valid_implicit"] and result["valid_explicit"]
            and result["explicit_quasi_static"]
            and result["force_rms_diff_rel"] <= targets.force_rms
            and result["shape_rms_diff_rel_thickness"] <= targets.shape_rms
            and result["energy_balance_error_rel"] <= targets.energy_balance)
        pngs = _plots(out, response, curves, exp, dist, imp.shape, case)
        _report(out, case, result, shared, pngs, assignments)
        from forming.output import json_safe

        (out / "compare.json").write_text(json.dumps(json_safe(result), indent=2) + "\n")
    return comm.bcast(result, root=0)
