"""What a study's runs say: ``study.csv``, ``study.md`` and the PNGs.

For each metric: its value against the varied parameter; where a parameter refines a mesh
or a step (three or more completed levels, the other parameters fixed), the observed
order, the Richardson-extrapolated value and its grid-convergence index
(:mod:`forming.post.convergence`); and the error against the wall time, with the runs no
other run beats in both (the Pareto front) marked.

The representative size ``h`` of a level: for a tuple of counts (``cells=8,8,2``) the
inverse of their geometric mean; for a number, the number itself when it is a size or a
step (the unknowns fall or stay as it grows) and its inverse when it is a count (the
unknowns grow with it).
"""

from __future__ import annotations

import csv
import itertools
import math
from dataclasses import dataclass
from pathlib import Path

from forming.output import plot_curves
from forming.post.convergence import Extrapolation, judge, pareto_front
from forming.study import FIXED_COLUMNS, Row, Study


def _numbers(text: str) -> tuple[float, ...] | None:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        return None


def level_sizes(rows: list[Row], key: str) -> list[float] | None:
    """The representative size ``h`` of each row's level of ``key``, or None (categorical).

    Rows must differ in ``key`` only (one group).
    """
    parsed = [_numbers(r.values[key]) for r in rows]
    if any(p is None for p in parsed) or any(min(p) <= 0.0 for p in parsed):
        return None
    if any(len(p) > 1 for p in parsed):  # counts per direction
        return [1.0 / math.prod(p) ** (1.0 / len(p)) for p in parsed]
    v = [p[0] for p in parsed]
    pairs = sorted((a, r.unknowns) for a, r in zip(v, rows, strict=True) if r.unknowns)
    counts = len(pairs) >= 2 and all(b[1] > a[1] for a, b in itertools.pairwise(pairs))
    return [1.0 / a for a in v] if counts else v


@dataclass(frozen=True)
class Convergence:
    """One metric over one varied parameter (the others fixed at ``fixed``).

    ``why``: why ``result`` is None, in words (empty when there is one).
    """

    metric: str
    key: str
    fixed: dict[str, str]
    rows: list[Row]
    h: list[float] | None
    result: Extrapolation | None
    why: str


def groups(rows: list[Row], key: str) -> list[tuple[dict[str, str], list[Row]]]:
    """The rows split by the values of the other varied parameters."""
    out: dict[tuple, list[Row]] = {}
    for r in rows:
        fixed = tuple((k, v) for k, v in r.values.items() if k != key)
        out.setdefault(fixed, []).append(r)
    return [(dict(k), v) for k, v in out.items()]


def convergence(study: Study, rows: list[Row], metric: str) -> list[Convergence]:
    """Every (varied parameter, group) of completed runs holding ``metric``."""
    found = []
    for vary in study.varies:
        for fixed, members in groups(rows, vary.key):
            done = [r for r in members if r.status == "completed" and metric in r.metrics]
            h = level_sizes(done, vary.key) if done else None
            result, why = (judge(h, [r.metrics[metric] for r in done]) if h is not None
                           else (None, "not a size, no order"))
            found.append(Convergence(metric, vary.key, fixed, done, h, result, why))
    return found


def reference(study: Study, rows: list[Row], metric: str) -> tuple[float, str] | None:
    """The value errors are measured against, and how it was found."""
    done = [r for r in rows if r.status == "completed" and metric in r.metrics]
    if not done:
        return None
    if study.reference not in ("finest", "extrapolated"):
        return float(study.reference), "given"
    if study.reference == "extrapolated":
        found = [c for c in convergence(study, rows, metric) if c.result is not None]
        if found:
            best = max(found, key=lambda c: max(r.unknowns for r in c.rows))
            return best.result.value, f"extrapolated over {best.key}"
    finest = max(done, key=lambda r: (r.unknowns, done.index(r)))
    return finest.metrics[metric], f"finest run ({finest.folder.name})"


def errors(study: Study, rows: list[Row], metric: str) -> list[float]:
    """Relative error of each row's metric (NaN where it has none)."""
    ref = reference(study, rows, metric)
    out = []
    for r in rows:
        ok = ref is not None and r.status == "completed" and metric in r.metrics
        out.append(abs(r.metrics[metric] - ref[0]) / max(abs(ref[0]), 1e-300)
                   if ok else float("nan"))
    return out


def write_csv(study: Study, rows: list[Row], metrics: list[str], path: Path) -> Path:
    """``study.csv``: one row per run."""
    keys = [v.key for v in study.varies]
    errs = {m: errors(study, rows, m) for m in metrics}
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys + list(FIXED_COLUMNS) + metrics + [f"error_{m}" for m in metrics]
                   + ["reused", "folder", "reason"])
        for i, r in enumerate(rows):
            w.writerow([r.values[k] for k in keys]
                       + [getattr(r, c) for c in FIXED_COLUMNS]
                       + [r.metrics.get(m, "") for m in metrics]
                       + [("" if math.isnan(errs[m][i]) else errs[m][i]) for m in metrics]
                       + [r.reused, r.folder.name, r.reason])
    return path


def metric_plot(study: Study, rows: list[Row], metric: str, out: Path) -> Path:
    """``<metric>.png``: the metric at each level, with the extrapolated value if any."""
    curves, title, xlabel, notes = [], metric, "level", []
    for c in convergence(study, rows, metric):
        if not c.rows:
            continue
        label = ", ".join(f"{k}={v}" for k, v in c.fixed.items()) or metric
        if c.h is not None:
            x = c.h
            xlabel = f"representative size h of {c.key} (finest left)"
        else:
            x = list(range(len(c.rows)))
            xlabel = f"{c.key} (level)"
        pts = sorted(zip(x, [r.metrics[metric] for r in c.rows],
                         [r.values[c.key] for r in c.rows], strict=True))
        curves.append(([p[0] for p in pts], [p[1] for p in pts], label, "o-"))
        notes += pts
        if c.result is not None:
            e = c.result
            span = [0.0, max(x)]
            curves.append((span, [e.value] * 2, f"extrapolated {e.value:.6g}", "k--"))
            curves.append((span, [e.value - e.uncertainty] * 2, f"GCI band {100 * e.gci:.2g}%",
                           "k:"))
            curves.append((span, [e.value + e.uncertainty] * 2, "_", "k:"))
            title = f"{metric}: observed order {e.order:.2f}"
    return plot_curves(out / f"{metric}.png", curves, xlabel, metric, title, notes=notes)


def error_time_plot(study: Study, rows: list[Row], metric: str, out: Path) -> Path | None:
    """``error_vs_time_<metric>.png``: error against wall time, the Pareto front joined."""
    err = errors(study, rows, metric)
    pts = [(r.wall_s, e, r) for r, e in zip(rows, err, strict=True)
           if not math.isnan(e) and e > 0.0 and r.wall_s > 0.0]
    if not pts:
        return None
    front = pareto_front([p[0] for p in pts], [p[1] for p in pts])
    ref = reference(study, rows, metric)
    curves = [([p[0] for p in pts], [p[1] for p in pts], "runs", "o"),
              ([pts[i][0] for i in front], [pts[i][1] for i in front], "Pareto front", "r-s")]
    notes = [(t, e, ", ".join(r.values.values())) for t, e, r in pts]
    return plot_curves(out / f"error_vs_time_{metric}.png", curves, "wall time [s]",
                       f"relative error of {metric}", f"against the {ref[1]}",
                       logx=True, logy=True, notes=notes)


def _fmt(v: float) -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.6g}"


def write_markdown(study: Study, rows: list[Row], metrics: list[str], pngs: list[Path],
                   path: Path) -> Path:
    """``study.md``: the table, the convergence of each metric, the plots."""
    keys = [v.key for v in study.varies]
    lines = [f"# Study of `{study.case}`", "",
             f"Varied: {', '.join(f'`{v.key}` = {list(v.values)}' for v in study.varies)}; "
             f"fixed: {', '.join(f'`{s}`' for s in study.sets) or 'the defaults'}; "
             f"{study.ranks} rank(s) per run. Errors are relative to the reference named "
             "under each metric.", "",
             "| " + " | ".join(keys + ["status", "wall [s]", "steps", "Newton", "unknowns",
                                      "peak MB"] + metrics) + " |",
             "|" + "---|" * (len(keys) + 6 + len(metrics))]
    for r in rows:
        lines.append("| " + " | ".join(
            [r.values[k] for k in keys] + [r.status, _fmt(r.wall_s), str(r.steps),
                                          str(r.newton_iterations), str(r.unknowns),
                                          _fmt(r.peak_rss_mb)]
            + [_fmt(r.metrics.get(m, float("nan"))) for m in metrics]) + " |")
    for m in metrics:
        ref = reference(study, rows, m)
        lines += ["", f"## `{m}`", ""]
        lines.append(f"Reference: {_fmt(ref[0])} ({ref[1]})." if ref else
                     "No completed run has it.")
        for c in convergence(study, rows, m):
            where = ", ".join(f"{k}={v}" for k, v in c.fixed.items())
            head = f"- over `{c.key}`" + (f" ({where})" if where else "")
            if c.result is not None:
                e = c.result
                lines.append(f"{head}: observed order {e.order:.2f}, extrapolated "
                             f"{e.value:.6g} +/- {e.uncertainty:.3g} (GCI {100 * e.gci:.2g}% "
                             f"of the finest; ratios {e.ratios[0]:.3g}, {e.ratios[1]:.3g})")
            else:
                lines.append(f"{head}: {c.why}; no extrapolation")
    lines += ["", "## Plots", ""] + [f"![{p.stem}]({p.name})" for p in pngs]
    path.write_text("\n".join(lines) + "\n")
    return path


def report(study: Study, rows: list[Row]) -> dict:
    """Write ``study.csv``, ``study.md`` and the PNGs into the study's folder."""
    metrics = list(study.metrics) or sorted(
        {m for r in rows if r.status == "completed" for m in r.metrics})
    out = study.out
    pngs: list[Path] = []
    for m in metrics:
        if any(m in r.metrics for r in rows if r.status == "completed"):
            pngs.append(metric_plot(study, rows, m, out))
            p = error_time_plot(study, rows, m, out)
            if p is not None:
                pngs.append(p)
    csv_path = write_csv(study, rows, metrics, out / "study.csv")
    md = write_markdown(study, rows, metrics, pngs, out / "study.md")
    conv = {m: [{"key": c.key, "fixed": c.fixed, "order": c.result.order,
                 "extrapolated": c.result.value, "gci": c.result.gci}
                for c in convergence(study, rows, m) if c.result is not None]
            for m in metrics}
    return {"csv": csv_path, "md": md, "pngs": pngs, "convergence": conv,
            "runs": len(rows), "completed": sum(r.status == "completed" for r in rows),
            "reused": sum(r.reused for r in rows)}
