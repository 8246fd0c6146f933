"""Tabulated material curves: validation, CSV input and monotone interpolation."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from forming.errors import InputError


@dataclass(frozen=True)
class CompressionCurve:
    """Nominal uniaxial compression curve (compression positive), as a C365 test gives it.

    Attributes:
        strain: Nominal (engineering) strains, starting at 0, strictly increasing, < 1.
        stress: Nominal stresses [MPa] at those strains, starting at 0, non-negative.
        source: Where the data come from (file path or citation).
    """

    strain: tuple[float, ...]
    stress: tuple[float, ...]
    source: str = "user"

    def __post_init__(self) -> None:
        e = np.asarray(self.strain, dtype=float)
        s = np.asarray(self.stress, dtype=float)
        where = f" (curve from {self.source})"
        if e.ndim != 1 or e.size < 3:
            raise InputError("curve.strain", "needs at least 3 points" + where)
        if s.shape != e.shape:
            raise InputError(
                "curve.stress", f"has {s.size} values but curve.strain has {e.size}" + where
            )
        if not (np.all(np.isfinite(e)) and np.all(np.isfinite(s))):
            raise InputError("curve", "contains a non-finite value" + where)
        if e[0] != 0.0 or s[0] != 0.0:
            raise InputError("curve", "must start at (strain 0, stress 0)" + where)
        bad = np.nonzero(np.diff(e) <= 0)[0]
        if bad.size:
            i = int(bad[0]) + 1
            raise InputError(
                "curve.strain",
                f"is not monotonic: point {i} (strain {e[i]:g}) does not exceed "
                f"point {i - 1} (strain {e[i - 1]:g}); strains must strictly increase" + where,
            )
        if e[-1] >= 1.0:
            raise InputError("curve.strain", f"nominal strain must stay below 1, got {e[-1]:g}")
        if np.any(s[1:] <= 0):
            i = int(np.nonzero(s[1:] <= 0)[0][0]) + 1
            raise InputError(
                "curve.stress", f"must be positive after the origin, point {i} has {s[i]:g}" + where
            )

    @classmethod
    def from_csv(cls, path: str | Path) -> CompressionCurve:
        """Read a two-column CSV (nominal strain, nominal stress in MPa) with a header row.

        Lines starting with ``#`` are comments.

        Raises:
            InputError: The file is missing or malformed (the message names the line).
        """
        p = Path(path)
        if not p.is_file():
            raise InputError("curve.path", f"file not found: {p}")
        strain: list[float] = []
        stress: list[float] = []
        with p.open(newline="") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
        if not rows:
            raise InputError("curve.path", f"{p} holds no data")
        header, body = rows[0], rows[1:]
        try:
            float(header[0])
            body = rows  # no header row
        except ValueError:
            pass
        for n, row in enumerate(body, start=1):
            if len(row) < 2:
                raise InputError("curve.path", f"{p}: row {n} has {len(row)} column(s), needs 2")
            try:
                strain.append(float(row[0]))
                stress.append(float(row[1]))
            except ValueError as exc:
                raise InputError("curve.path", f"{p}: row {n} is not numeric: {row!r}") from exc
        return cls(tuple(strain), tuple(stress), source=str(p))

    def to_csv(self, path: str | Path, comment: str = "") -> Path:
        """Write the curve in the format :meth:`from_csv` reads (``comment``: ``#`` lines)."""
        p = Path(path)
        lines = [f"# {line}" for line in comment.splitlines()]
        lines.append("nominal_strain,nominal_stress_MPa")
        lines += [f"{float(e)!r},{float(s)!r}" for e, s in zip(self.strain, self.stress,
                                                                strict=True)]
        p.write_text("\n".join(lines) + "\n")
        return p

    def interpolate(self, e: np.ndarray) -> np.ndarray:
        """Piecewise-linear nominal stress at nominal strains ``e``."""
        return np.interp(e, self.strain, self.stress)


def pchip_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Fritsch-Carlson slopes of the monotone piecewise cubic Hermite interpolant."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    h = np.diff(x)
    delta = np.diff(y) / h
    d = np.zeros_like(y)
    for k in range(1, len(x) - 1):
        if delta[k - 1] * delta[k] <= 0:
            d[k] = 0.0
        else:
            w1 = 2 * h[k] + h[k - 1]
            w2 = h[k] + 2 * h[k - 1]
            d[k] = (w1 + w2) / (w1 / delta[k - 1] + w2 / delta[k])

    def end(h0: float, h1: float, d0: float, d1: float) -> float:
        s = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
        if math.copysign(1, s) != math.copysign(1, d0):
            return 0.0
        if math.copysign(1, d0) != math.copysign(1, d1) and abs(s) > abs(3 * d0):
            return 3 * d0
        return s

    if len(x) == 2:
        d[:] = delta[0]
    else:
        d[0] = end(h[0], h[1], delta[0], delta[1])
        d[-1] = end(h[-1], h[-2], delta[-1], delta[-2])
    return d
