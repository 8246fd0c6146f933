"""Hardening curve of the crushable foam: piecewise cubic Hermite evaluation and slope bound.

The compression strength ``pc(evp)`` is a table of values and slopes;
:func:`hermite_eval` interpolates it (constant below the table, linear above), and
:func:`_hermite_slope_bound` bounds its slope over the whole line (the Lipschitz
constant used by the return mapping's lower bound).
"""

from __future__ import annotations

from .common import _inner


@_inner
def hermite_eval(x, xs, ys, ds):
    """Piecewise cubic Hermite value and slope; constant below ``xs[0]``, linear above.

    Args:
        x: Abscissa.
        xs: Table abscissae (increasing).
        ys: Table values.
        ds: Table slopes.

    Returns:
        (value, slope) at ``x``.
    """
    n = xs.shape[0]
    if x <= xs[0]:
        return ys[0], 0.0
    if x >= xs[n - 1]:
        return ys[n - 1] + ds[n - 1] * (x - xs[n - 1]), ds[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    h = xs[hi] - xs[lo]
    t = (x - xs[lo]) / h
    t2 = t * t
    t3 = t2 * t
    h00 = 2 * t3 - 3 * t2 + 1
    h10 = t3 - 2 * t2 + t
    h01 = -2 * t3 + 3 * t2
    h11 = t3 - t2
    y = h00 * ys[lo] + h10 * h * ds[lo] + h01 * ys[hi] + h11 * h * ds[hi]
    dh00 = (6 * t2 - 6 * t) / h
    dh10 = 3 * t2 - 4 * t + 1
    dh01 = (-6 * t2 + 6 * t) / h
    dh11 = 3 * t2 - 2 * t
    dy = dh00 * ys[lo] + dh10 * ds[lo] + dh01 * ys[hi] + dh11 * ds[hi]
    return y, dy


@_inner
def _hermite_slope_bound(xs, ys, ds):
    """Bound on ``|dy/dx|`` of :func:`hermite_eval` over the whole real line.

    On each interval the slope is a quadratic in the local coordinate, so its
    largest magnitude is at an end or at the vertex. Intervals of zero width are
    never evaluated and are skipped.

    Args:
        xs: Table abscissae (increasing).
        ys: Table values.
        ds: Table slopes.

    Returns:
        The Lipschitz constant of the curve.
    """
    n = xs.shape[0]
    bound = abs(ds[n - 1])
    for i in range(n - 1):
        h = xs[i + 1] - xs[i]
        if not h > 0.0:
            continue
        # slope = a t^2 + b t + c for t in [0, 1]
        a = (6.0 * (ys[i] - ys[i + 1]) + 3.0 * h * (ds[i] + ds[i + 1])) / h
        b = (6.0 * (ys[i + 1] - ys[i]) - h * (4.0 * ds[i] + 2.0 * ds[i + 1])) / h
        c = ds[i]
        bound = max(bound, abs(c), abs(a + b + c))
        if a != 0.0 and 0.0 < -b / (2.0 * a) < 1.0:
            bound = max(bound, abs(c - b * b / (4.0 * a)))
    return bound
