"""Observed order of convergence, Richardson extrapolation and the grid-convergence index.

The procedure of Celik et al. (2008, ASME J. Fluids Eng. 130, 078001), after Roache
(1994): three solutions ``f1, f2, f3`` on representative sizes ``h1 < h2 < h3`` (finest
first) with ratios ``r21 = h2 / h1`` and ``r32 = h3 / h2`` that need not be equal. With
``f = f0 + C h^p``, ``e21 = f2 - f1`` and ``e32 = f3 - f2``, the observed order ``p``
solves

    e32 / e21 = r21^p (r32^p - 1) / (r21^p - 1),

(solved directly, see :func:`observed_order`); the extrapolated
value is ``(r21^p f1 - f2) / (r21^p - 1)``, and the fine-grid convergence index
``1.25 |(f1 - f2) / f1| / (r21^p - 1)`` bounds the relative error of ``f1`` with about
95% confidence when the solutions are in the asymptotic range. Only monotonic
convergence (``e32 / e21 > 0``) is extrapolated: oscillating or diverging levels say so
instead of giving a number.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

SAFETY = 1.25  # Roache's factor of safety for three or more levels
MIN_ORDER = 0.5
"""Smallest observed order extrapolated from. Far below any element's formal order the
levels are not in the asymptotic range, and the extrapolation reaches far outside them
(its step from the finest level grows as 1 / (r^p - 1)): a shear modulus drifting by
0.2% per level gave order 0.06 and a value 5% away."""


@dataclass(frozen=True)
class Extrapolation:
    """What three levels of a study say about the converged value.

    Attributes:
        order: Observed order of convergence ``p``.
        value: Richardson-extrapolated value.
        gci: Fine-grid convergence index: the relative uncertainty of the finest value.
        uncertainty: ``gci`` times the finest value (same units).
        ratios: The refinement ratios ``(r21, r32)``.
    """

    order: float
    value: float
    gci: float
    uncertainty: float
    ratios: tuple[float, float]


def convergence_kind(f: Sequence[float]) -> str:
    """``"monotonic"``, ``"oscillating"`` or ``"converged"`` for three values, finest first.

    ``"converged"``: the two finest agree to round-off, so no order can be observed.
    """
    e21, e32 = f[1] - f[0], f[2] - f[1]
    scale = max(abs(v) for v in f) or 1.0
    if abs(e21) <= 1e-12 * scale:
        return "converged"
    return "monotonic" if e32 / e21 > 0.0 else "oscillating"


def observed_order(h: Sequence[float], f: Sequence[float]) -> float:
    """The observed order ``p`` for sizes ``h`` (finest first) and values ``f``.

    Solves ``e32 / e21 = r21^p (r32^p - 1) / (r21^p - 1)`` for ``p > 0`` (the relation
    behind Celik et al.'s fixed point, without its absolute values), by bisection on the
    logarithm. The right-hand side grows from ``ln r32 / ln r21`` at ``p -> 0``, so a
    ratio of differences at or below that has no positive order: the differences do not
    shrink fast enough under refinement for the levels to be converging. (The fixed point
    with absolute values returns a positive number there too.)

    Raises:
        ValueError: The sizes are not strictly increasing, the values do not change
            monotonically, or no positive order fits them.
    """
    h1, h2, h3 = h
    if not 0.0 < h1 < h2 < h3:
        raise ValueError(f"sizes must grow from the finest level: {tuple(h)}")
    if convergence_kind(f) != "monotonic":
        raise ValueError(f"no observed order: the values {tuple(f)} are "
                         f"{convergence_kind(f)}")
    r21, r32 = h2 / h1, h3 / h2
    target = math.log((f[2] - f[1]) / (f[1] - f[0]))

    def g(p: float) -> float:  # log of the model's ratio of differences, increasing in p
        return p * math.log(r21) + math.log(math.expm1(p * math.log(r32))
                                            / math.expm1(p * math.log(r21)))

    lo, hi = 1e-9, 1.0
    if target <= g(lo):
        raise ValueError(f"no positive order: the values {tuple(f)} change more on the "
                         "finer levels than a converging sequence can")
    while g(hi) < target:
        hi *= 2.0
        if hi > 1e3:
            raise ValueError(f"no finite order fits the values {tuple(f)}")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if g(mid) < target else (lo, mid)
        if hi - lo < 1e-13 * hi:
            break
    return 0.5 * (lo + hi)


def judge(h: Sequence[float], f: Sequence[float]) -> tuple[Extrapolation | None, str]:
    """Richardson extrapolation from the three finest of several levels, or why there is none.

    Args:
        h: Representative sizes of the levels (any order).
        f: The quantity at each level.

    Returns:
        The extrapolation and ``""``, or None and the reason in words: fewer than three
        distinct levels, the three finest oscillate, agree to round-off, change more on
        the finer levels than a converging sequence can, or converge with an observed
        order below :data:`MIN_ORDER`.
    """
    levels = sorted(zip(h, f, strict=True))[:3]
    hs = [a for a, _ in levels]
    fs = [b for _, b in levels]
    if len(set(hs)) < 3:
        return None, "fewer than three levels to judge"
    kind = convergence_kind(fs)
    if kind == "oscillating":
        return None, "the three finest levels oscillate"
    if kind == "converged":
        return None, "the two finest levels agree to round-off"
    try:
        p = observed_order(hs, fs)
    except ValueError:  # monotonic, but not converging
        return None, ("the three finest levels change more on the finer levels than a "
                      "converging sequence can")
    if p < MIN_ORDER:
        return None, (f"the three finest levels converge too slowly to extrapolate "
                      f"(observed order {p:.2g}, below {MIN_ORDER:g})")
    r21 = hs[1] / hs[0]
    gain = r21 ** p - 1.0
    value = (r21 ** p * fs[0] - fs[1]) / gain
    gci = SAFETY * abs((fs[0] - fs[1]) / fs[0]) / gain if fs[0] else math.inf
    return Extrapolation(order=p, value=value, gci=gci, uncertainty=gci * abs(fs[0]),
                         ratios=(r21, hs[2] / hs[1])), ""


def extrapolate(h: Sequence[float], f: Sequence[float]) -> Extrapolation | None:
    """The extrapolation of :func:`judge`, or None."""
    return judge(h, f)[0]


def why_not(h: Sequence[float], f: Sequence[float]) -> str:
    """Why :func:`judge` gives no extrapolation for these levels, in words."""
    return judge(h, f)[1] or "it extrapolates"


def pareto_front(cost: Sequence[float], error: Sequence[float]) -> list[int]:
    """Indices of the runs no other run beats in both cost and error (cheapest first)."""
    order = sorted(range(len(cost)), key=lambda i: (cost[i], error[i]))
    front, best = [], math.inf
    for i in order:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return front
