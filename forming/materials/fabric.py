"""Dry biaxial non-crimp fabric (NCF) skin: fibre tension, picture-frame shear, soft matrix.

The skin is a one-element-thick solid layer of reference thickness ``t`` lying in the x-y
plane. Its strain energy per unit reference volume is split into two parts that the caller
integrates differently:

* :meth:`NonCrimpFabric.membrane_energy`: tension/compression of the two fibre families
  and the picture-frame shear energy ``W_s(gamma) / t``. It is meant to be integrated at
  the mid-surface only, so fibre tension gives the layer no bending stiffness: a dry
  fabric bends with a few N mm, whereas 35 GPa integrated through 0.4 mm would give
  ``E t^3 / 12`` = 187 N mm per mm of width.
* :meth:`NonCrimpFabric.matrix_energy`: a soft compressible neo-Hookean matrix plus a
  transverse-shear term, integrated through the thickness. It carries what a membrane
  cannot: contact pressure across the layer and friction tractions on its faces.

**Shear angle.** ``gamma = theta0 - theta``, where ``theta`` is the angle between the
deformed fibres ``F a1`` and ``F a2`` and ``theta0`` the reference one, both measured
around the bisector ``a1 + a2`` (for the default +/-45 deg fibres: the x-axis, the 0 deg
roll direction along which the pillar stitch runs). ``gamma > 0`` when the fibres close
up around the bisector, i.e. the fabric is stretched along the stitch and shortened across
it: ``F = diag(1.1, 1/1.1, 1)`` gives ``gamma = +10.9 deg``, ``diag(1/1.1, 1.1, 1)`` gives
``-10.9 deg``. The paper says only that the shear response is asymmetric because of the
pillar stitch at 0 deg (its Fig. 2) and that wrinkling starts at +42 / -50 deg; it does not
define the sign. Positive is taken as stitch in tension: a stretched stitch adds resistance
and compacts the tows, hence the stiffer branch with the earlier wrinkling (42 deg), as in
the estimated curves. As far as we know (not checked here), this is the convention of the
authors' earlier picture-frame work on this fabric (the paper's refs. [23-25]).

Units: mm, N, MPa; picture-frame force per unit side length and torque per unit area in
N/mm, shear energy per unit area in N/mm (mJ/mm^2).
"""

from __future__ import annotations

import csv
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
import ufl

from forming.errors import InputError
from forming.materials.curves import pchip_slopes

COLUMNS = ("shear_deg", "force_positive_N_per_mm", "force_negative_N_per_mm")
DEFAULT_CSV = "fabric_picture_frame_estimate.csv"
_FIELDS = ("shear_deg", "force_positive", "force_negative")


def _validate(values: tuple, label: Callable[[int], str], where: str) -> None:
    """Check angle and force columns; ``label(i)`` names point ``i`` (row or line)."""
    try:
        cols = [np.asarray(v, dtype=float).ravel() for v in values]
    except (TypeError, ValueError) as exc:
        raise InputError("shear", f"values must be numbers{where}") from exc
    n = cols[0].size
    if n < 3:
        raise InputError("shear.shear_deg", f"needs at least 3 points, got {n}{where}")
    for name, c in zip(_FIELDS[1:], cols[1:], strict=True):
        if c.size != n:
            raise InputError(f"shear.{name}", f"has {c.size} values, shear_deg {n}{where}")
    for i in range(n):
        for name, c in zip(_FIELDS, cols, strict=True):
            if not math.isfinite(c[i]):
                raise InputError(f"shear.{name}", f"{label(i)}: {c[i]!r} is not finite{where}")
        a = cols[0]
        if not 0.0 < a[i] < 90.0:
            raise InputError("shear.shear_deg",
                             f"{label(i)}: angle {a[i]:g} must lie in (0, 90) deg{where}")
        if i and a[i] <= a[i - 1]:
            raise InputError("shear.shear_deg", f"{label(i)}: angle {a[i]:g} does not exceed "
                             f"the previous {a[i - 1]:g}; angles must strictly increase{where}")
        for name, c in zip(_FIELDS[1:], cols[1:], strict=True):
            if c[i] < 0.0:
                raise InputError(f"shear.{name}", f"{label(i)}: force {c[i]:g} < 0{where}")
            if i and c[i] < c[i - 1]:
                raise InputError(f"shear.{name}", f"{label(i)}: force {c[i]:g} decreases from "
                                 f"{c[i - 1]:g}; forces must not decrease{where}")


def _poly(s, coef, energy: bool):
    """Torque ``b0 + b1 s + b2 s^2 + b3 s^3`` or its integral from 0 plus ``w0`` (NumPy or UFL)."""
    _, w0, b0, b1, b2, b3 = coef
    if energy:
        return w0 + s * (b0 + s * (b1 / 2.0 + s * (b2 / 3.0 + s * (b3 / 4.0))))
    return b0 + s * (b1 + s * (b2 + s * b3))


@dataclass(frozen=True)
class ShearCurve:
    """Picture-frame shear curve: normalised shear force against shear angle, two branches.

    ``F_norm = F L / (2 cos(phi) S)`` [N/mm] is the picture-frame force normalised per unit
    side length (shared notes, material-data.md). The shear torque per unit reference area
    is ``C_s = F_norm cos(gamma)`` and the shear energy per unit area ``W_s = int_0^gamma C_s``.

    Interpolation: each branch interpolates the torque ``C_s`` itself (not ``F_norm``)
    through (0, 0) and the data points with a monotone piecewise cubic Hermite
    (Fritsch-Carlson slopes, as PCHIP), so that ``W_s`` is exactly its piecewise-quartic
    integral. Both branches take the same slope at 0, the harmonic mean of their first
    secants. That mean is at most twice the smaller secant, so each branch stays in the
    Fritsch-Carlson monotone region, and the signed torque is C1 (the energy C2) at 0.
    Beyond the last data point the torque continues linearly with its end slope (the
    energy quadratically). The signed torque is ``C_+(gamma)`` for ``gamma >= 0`` and
    ``-C_-(-gamma)`` below; the energy is non-negative on both sides.

    Attributes:
        shear_deg: Shear-angle magnitudes [deg], strictly increasing, in (0, 90).
        force_positive: ``F_norm`` [N/mm] of the positive branch at those angles.
        force_negative: ``F_norm`` [N/mm] of the negative branch at the same magnitudes.
        source: Where the data come from (file path or citation).
    """

    shear_deg: tuple[float, ...]
    force_positive: tuple[float, ...]
    force_negative: tuple[float, ...]
    source: str = "user"

    def __post_init__(self) -> None:
        _validate((self.shear_deg, self.force_positive, self.force_negative),
                  lambda i: f"point {i + 1}", f" (shear curve from {self.source})")

    @classmethod
    def from_csv(cls, path: str | Path) -> ShearCurve:
        """Read a CSV with header ``shear_deg,force_positive_N_per_mm,force_negative_N_per_mm``.

        Lines starting with ``#`` are comments; the columns may come in any order.

        Raises:
            InputError: Missing file, unknown or missing column, or invalid row (the
                message names the file and line).
        """
        p = Path(path)
        if not p.is_file():
            raise InputError("shear.path", f"file not found: {p}")
        with p.open(newline="") as fh:
            rows = [(n, r) for n, r in enumerate(csv.reader(fh), start=1)
                    if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
        if not rows:
            raise InputError("shear.path", f"{p} holds no data")
        (line, header), body = rows[0], rows[1:]
        names = [c.strip() for c in header]
        if sorted(names) != sorted(COLUMNS):
            unknown = [c for c in names if c not in COLUMNS]
            raise InputError("shear.path", f"{p}, line {line}: header {names}, unknown column(s) "
                             f"{unknown}; expected the columns {list(COLUMNS)}")
        idx = [names.index(c) for c in COLUMNS]
        cols: tuple[list[float], ...] = ([], [], [])
        lines = []
        for n, r in body:
            if len(r) != len(names):
                raise InputError("shear.path", f"{p}, line {n}: {len(r)} columns, expected 3")
            try:
                for c, j in zip(cols, idx, strict=True):
                    c.append(float(r[j]))
            except ValueError as exc:
                raise InputError("shear.path", f"{p}, line {n}: not numeric: {r!r}") from exc
            lines.append(n)
        _validate(cols, lambda i: f"line {lines[i]}", f" (in {p})")
        return cls(*(tuple(c) for c in cols), source=str(p))

    @classmethod
    def default(cls) -> ShearCurve:
        """The shipped estimate for the paper's FCIM359 NCF (see the CSV's comments)."""
        return _default_curve()

    @functools.cached_property
    def _pieces(self) -> tuple[np.ndarray, np.ndarray]:
        """Breakpoints (signed, rad) and per-piece rows ``(origin, W(origin), b0..b3)``.

        On a piece the torque is ``b0 + b1 s + b2 s^2 + b3 s^3`` with ``s = gamma - origin``.
        """
        x = np.radians(np.concatenate([[0.0], self.shear_deg]))
        h = np.diff(x)
        ys = [np.concatenate([[0.0], np.asarray(f) * np.cos(x[1:])])
              for f in (self.force_positive, self.force_negative)]
        s1, s2 = (y[1] / x[1] for y in ys)
        d0 = 2.0 * s1 * s2 / (s1 + s2) if s1 * s2 > 0.0 else 0.0
        branches = []
        for sign, y in zip((1.0, -1.0), ys, strict=True):
            d = pchip_slopes(x, y)
            d[0] = d0
            delta = np.diff(y) / h
            a2 = (3.0 * delta - 2.0 * d[:-1] - d[1:]) / h
            a3 = (d[:-1] + d[1:] - 2.0 * delta) / h**2
            w = np.concatenate([[0.0], np.cumsum(
                h * (y[:-1] + h * (d[:-1] / 2.0 + h * (a2 / 3.0 + h * a3 / 4.0))))])
            rows = [(sign * x[k], w[k], sign * y[k], d[k], sign * a2[k], a3[k])
                    for k in range(h.size)]
            rows.append((sign * x[-1], w[-1], sign * y[-1], d[-1], 0.0, 0.0))
            branches.append(rows)
        table = np.array(branches[1][::-1] + branches[0])
        return np.concatenate([-x[:0:-1], x]), table

    def _evaluate(self, gamma: np.ndarray | float, energy: bool) -> np.ndarray:
        breaks, table = self._pieces
        g = np.asarray(gamma, dtype=float)
        coef = np.moveaxis(table[np.searchsorted(breaks, g, side="right")], -1, 0)
        return _poly(g - coef[0], coef, energy)

    def torque(self, gamma_rad: np.ndarray | float) -> np.ndarray:
        """Signed shear torque per unit area ``C_s`` [N mm/mm^2] at shear angles [rad]."""
        return self._evaluate(gamma_rad, energy=False)

    def energy(self, gamma_rad: np.ndarray | float) -> np.ndarray:
        """Shear energy per unit area ``W_s = int_0^gamma C_s`` [N/mm] at angles [rad]."""
        return self._evaluate(gamma_rad, energy=True)

    def _select(self, gamma: ufl.core.expr.Expr) -> list[ufl.core.expr.Expr]:
        """UFL piece coefficients: one chain of conditionals on ``gamma`` per column."""
        breaks, table = self._pieces
        conds = [ufl.lt(gamma, float(b)) for b in breaks]
        cols = []
        for j in range(table.shape[1]):
            expr = ufl.as_ufl(float(table[-1, j]))
            for c, v in zip(reversed(conds), table[-2::-1, j], strict=True):
                expr = ufl.conditional(c, float(v), expr)
            cols.append(expr)
        return cols

    def torque_ufl(self, gamma: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """UFL twin of :meth:`torque` for a UFL scalar ``gamma`` [rad]."""
        coef = self._select(gamma)
        return _poly(gamma - coef[0], coef, energy=False)

    def energy_ufl(self, gamma: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """UFL twin of :meth:`energy`; its derivative in ``gamma`` is :meth:`torque_ufl`."""
        coef = self._select(gamma)
        return _poly(gamma - coef[0], coef, energy=True)


@functools.cache
def _default_curve() -> ShearCurve:
    return ShearCurve.from_csv(Path(str(resources.files("forming") / "data" / DEFAULT_CSV)))


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise InputError(f"fabric.{name}", f"must be a positive number, got {value!r}")


@dataclass(frozen=True)
class NonCrimpFabric:
    """Dry biaxial NCF ply as a hyperelastic layer (energies per unit reference volume).

    Matrix defaults (the matrix is numerical, not a property of the dry fabric):

    * ``shear_modulus`` 3e-4 MPa: in free picture-frame shear it adds about
      ``mu t tan(gamma) / cos(gamma)^2`` to the shear torque: 0.4-0.6% of the shipped
      curve's softer (negative) branch between 10 and 55 deg, less on the positive one
      (measured with ``cases/picture_frame.py``).
    * ``bulk_modulus`` 1 MPa: picture-frame shear shrinks the area by ``cos(gamma)``; with a
      free thickness the layer thickens at nearly constant volume, so ``K`` does not resist
      it. ``K`` gives the through-thickness stiffness: 18% thinning under the core's 0.25 MPa
      plateau, 43% under 1 MPa, with the ``ln J`` barrier against collapse. Where the
      thickness is held, it adds ``K ln(cos gamma)^2 / 2``: quartic at small angles, but of
      the order of ``W_s / t`` at 40 deg.
    * ``transverse_shear_modulus`` 1 MPa: a soft isotropic matrix cannot carry friction
      tractions on the layer's faces (0.1 MPa over 1e-3 MPa is a shear strain of order 100).
      The term ``G_t (C_xz^2 + C_yz^2) / 2`` does (strain 0.1 at 0.1 MPa) and is zero for
      any in-plane deformation with a change of thickness.

    Attributes:
        thickness: Ply thickness [mm] (reference thickness of the layer).
        fibre_modulus: Membrane-equivalent tensile modulus of a ply [MPa].
        compression_ratio: Fibre compression modulus over tension modulus, in (0, 1].
        fibre_angles_deg: Angles of the two fibre families from the x-axis in the x-y plane.
        shear: Picture-frame shear curve (default: the shipped estimate).
        bulk_modulus: Small-strain bulk modulus ``K`` of the matrix [MPa].
        shear_modulus: Shear modulus ``mu`` of the matrix [MPa].
        transverse_shear_modulus: ``G_t`` [MPa] of the transverse-shear term (0 disables it).
        critical_angles_deg: Wrinkling onset (positive > 0, negative < 0) [deg].
        toe_strain: Width of the fibres' toe, over which tension stiffness sets in.
        areal_mass: Mass per unit area of a ply [tonne/mm^2]: FCIM359's 440 g/m^2
            (stated); sets the layer's density (explicit dynamics).
    """

    thickness: float = 0.4
    fibre_modulus: float = 35000.0
    compression_ratio: float = 1e-3
    fibre_angles_deg: tuple[float, float] = (45.0, -45.0)
    shear: ShearCurve = field(default_factory=_default_curve)
    bulk_modulus: float = 1.0
    shear_modulus: float = 3e-4
    transverse_shear_modulus: float = 1.0
    critical_angles_deg: tuple[float, float] = (42.0, -50.0)
    toe_strain: float = 1e-3
    areal_mass: float = 4.4e-10

    @property
    def density(self) -> float:
        """Mass density of the layer [tonne/mm^3]: areal mass over ply thickness."""
        return self.areal_mass / self.thickness

    def __post_init__(self) -> None:
        for name in ("thickness", "fibre_modulus", "bulk_modulus", "shear_modulus",
                     "toe_strain", "areal_mass"):
            _positive(name, getattr(self, name))
        g = self.transverse_shear_modulus
        if not (isinstance(g, int | float) and math.isfinite(g) and g >= 0):
            raise InputError("fabric.transverse_shear_modulus", f"must be >= 0, got {g!r}")
        r = self.compression_ratio
        if not (isinstance(r, int | float) and 0.0 < r <= 1.0):
            raise InputError("fabric.compression_ratio", f"must lie in (0, 1], got {r!r}")
        a = self.fibre_angles_deg
        if len(a) != 2 or not all(isinstance(v, int | float) and math.isfinite(v) for v in a):
            raise InputError("fabric.fibre_angles_deg", f"needs two finite angles, got {a!r}")
        if abs(math.sin(math.radians(a[0] - a[1]))) < 1e-6:
            raise InputError("fabric.fibre_angles_deg", f"fibres {a} are parallel")
        c = self.critical_angles_deg
        if len(c) != 2 or not (0.0 < c[0] < 90.0 and -90.0 < c[1] < 0.0):
            raise InputError("fabric.critical_angles_deg",
                             f"needs (positive, negative) angles within 90 deg, got {c!r}")
        if not isinstance(self.shear, ShearCurve):
            raise InputError("fabric.shear", f"must be a ShearCurve, got {self.shear!r}")

    @property
    def fibre_directions(self) -> tuple[np.ndarray, np.ndarray]:
        """Reference unit fibre directions (3-vectors in the x-y plane)."""
        return tuple(np.array([math.cos(t), math.sin(t), 0.0])
                     for t in np.radians(self.fibre_angles_deg))

    def fibre_stretches(self, F: ufl.core.expr.Expr) -> tuple[ufl.core.expr.Expr, ...]:
        """Fibre stretches ``|F a0|`` of the two families."""
        return tuple(ufl.sqrt(ufl.dot(F * ufl.as_vector(a), F * ufl.as_vector(a)))
                     for a in self.fibre_directions)

    def shear_angle(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Signed shear angle [rad]: positive closes the fibres around their bisector."""
        a1, a2 = self.fibre_directions
        f1, f2 = F * ufl.as_vector(a1), F * ufl.as_vector(a2)
        c = ufl.dot(f1, f2) / ufl.sqrt(ufl.dot(f1, f1) * ufl.dot(f2, f2))
        lim = 1.0 - 1e-12
        theta0 = math.acos(float(np.dot(a1, a2)))
        return theta0 - ufl.acos(ufl.max_value(ufl.min_value(c, lim), -lim))

    def membrane_energy(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Fibre tension/compression plus picture-frame shear energy ``W_s(gamma)/t``.

        Per family ``E (lam - 1)^2 / 2`` with ``E`` the fibre modulus for ``lam > 1`` and
        ``compression_ratio`` times it below (the first derivative is continuous).
        """
        return self.fibre_energy(F) + self.shear_energy(F)

    def fibre_energy(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Tension/compression energy of the two fibre families (part of the membrane).

        Per family ``E/2 [r e^2 + (1 - r) g(e)]``, ``e = lam - 1``, ``r`` the compression
        ratio. ``g`` switches the tensile stiffness on over a toe of width ``toe_strain``
        (the tows' waviness): ``g = 0`` for ``e <= 0``, ``g'' = 2 s(e / toe)`` with ``s``
        the cubic smoothstep inside the toe, ``g = e^2 - toe e + 0.3 toe^2`` beyond it. The
        tangent is continuous (a jump of ``1/r`` at ``e = 0`` makes Newton cycle when many
        fibres sit at their natural length, as in a picture frame); the stress is
        ``E (e - (1 - r) toe / 2)`` in tension beyond the toe.
        """
        e_mod, r, d = self.fibre_modulus, self.compression_ratio, self.toe_strain
        psi = 0.0
        for lam in self.fibre_stretches(F):
            e = lam - 1.0
            x = e / d
            toe = 2.0 * d**2 * (x**4 / 4.0 - x**5 / 10.0)
            g = ufl.conditional(ufl.le(e, 0.0), 0.0,
                                ufl.conditional(ufl.lt(e, d), toe, e**2 - d * e + 0.3 * d**2))
            psi = psi + 0.5 * e_mod * (r * e**2 + (1.0 - r) * g)
        return psi

    def fibre_tangent_modulus(self, lam: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """``d^2 psi / d lam^2`` of one family at stretch ``lam`` [MPa] (:meth:`fibre_energy`).

        ``E r`` in compression, ``E`` beyond the toe, ``E [r + (1 - r) s(e / toe)]`` with the
        cubic smoothstep ``s`` inside it.
        """
        e_mod, r, d = self.fibre_modulus, self.compression_ratio, self.toe_strain
        x = (lam - 1.0) / d
        s = ufl.conditional(ufl.le(x, 0.0), 0.0,
                            ufl.conditional(ufl.lt(x, 1.0), x * x * (3.0 - 2.0 * x), 1.0))
        return e_mod * (r + (1.0 - r) * s)

    def taut_fibre_energy(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """``E (lam - 1)^2 / 2`` per family: the fibres as stiff as they get (in tension).

        Its second variation bounds the fibre stiffness of every state from above (the
        explicit solver's stable time step: at rest the fibres sit in their toe with
        ``compression_ratio`` times that stiffness).
        """
        return sum(0.5 * self.fibre_modulus * (lam - 1.0) ** 2
                   for lam in self.fibre_stretches(F))

    def shear_energy(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Picture-frame shear energy per unit volume ``W_s(gamma) / t``."""
        return self.shear.energy_ufl(self.shear_angle(F)) / self.thickness

    def matrix_energy(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Compressible neo-Hookean matrix plus the transverse-shear term.

        ``mu/2 (tr C - 3 - 2 ln J) + lam/2 (ln J)^2 + G_t/2 (C_xz^2 + C_yz^2)`` with
        ``lam = K - 2 mu/3``, so that ``K`` is the small-strain bulk modulus.
        """
        mu, lam = self.shear_modulus, self.bulk_modulus - 2.0 * self.shear_modulus / 3.0
        c = F.T * F
        ln_j = ufl.ln(ufl.det(F))
        psi = 0.5 * mu * (ufl.tr(c) - 3.0 - 2.0 * ln_j) + 0.5 * lam * ln_j**2
        if self.transverse_shear_modulus > 0.0:
            psi = psi + 0.5 * self.transverse_shear_modulus * (c[0, 2] ** 2 + c[1, 2] ** 2)
        return psi

    def energy(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Total strain energy per unit reference volume (membrane + matrix)."""
        return self.membrane_energy(F) + self.matrix_energy(F)

    def wrinkling_indicator(self, gamma: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """1 where ``gamma`` [rad] is beyond a critical wrinkling angle, else 0 (output)."""
        hi, lo = (math.radians(v) for v in self.critical_angles_deg)
        return ufl.conditional(ufl.Or(ufl.gt(gamma, hi), ufl.lt(gamma, lo)), 1.0, 0.0)
