"""Solid materials evaluated at quadrature points: elastic and crushable foam.

Both work in the Lagrangian generalised-strain space (Hencky or Biot strain) with
the elasticity of :mod:`forming.materials.elasticity`; see ``docs/theory.md``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import cached_property
from typing import Literal, NamedTuple, Protocol

import numpy as np

from forming.errors import InputError
from forming.log import collective_warning
from forming.materials import kernels
from forming.materials.curves import CompressionCurve, pchip_slopes
from forming.materials.elasticity import Elasticity
from forming.materials.kernels import N_PROPS, PROP_ALPHA, PROP_PT, PROP_VISC
from forming.materials.kernels.damage import DAMAGE_RATE, damage_points

log = logging.getLogger(__name__)

StrainMeasure = Literal["hencky", "biot", "biot-hencky"]

_TANGENTS = {"closed": kernels.TANGENT_CLOSED, "difference": kernels.TANGENT_DIFFERENCE}

_MEASURES = {
    "hencky": kernels.MEASURE_HENCKY,
    "biot": kernels.MEASURE_BIOT,
    "biot-hencky": kernels.MEASURE_BIOT_HENCKY,
}


class KernelData(NamedTuple):
    """Arrays handed to the point kernels of :mod:`forming.materials.kernels`."""

    cel: np.ndarray
    measure: int
    plastic: bool
    props: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    ds: np.ndarray
    damage: bool = False  # history is damage (:mod:`.kernels.damage`), not plasticity


class PointMaterial(Protocol):
    """A solid whose stress and tangent come from a quadrature-point kernel."""

    @property
    def plastic(self) -> bool:
        """Whether the material carries plastic state (and runs a return mapping)."""

    def kernel_data(self) -> KernelData:
        """The arrays the point kernel needs."""


class PointResult(NamedTuple):
    """Stress, tangent and trial state at a set of points."""

    S: np.ndarray  # (n, 6) second Piola-Kirchhoff stress, Mandel
    D: np.ndarray | None  # (n, 36) dS/dE_GL, Mandel row-major
    ep: np.ndarray | None  # (n, 6) plastic strain
    evp: np.ndarray | None  # (n,) volumetric plastic strain
    n_failed: int
    worst_status: int


def evaluate(
    material: PointMaterial,
    cmats: np.ndarray,
    ep_n: np.ndarray | None = None,
    evp_n: np.ndarray | None = None,
    want_tangent: bool = True,
    h: float = 1e-6,
    load_increment: float = 0.0,
    frozen: bool = False,
    travel: float = 1.0,
    tangent: Literal["closed", "difference"] = "closed",
    cells: tuple[np.ndarray, int] | None = None,
) -> PointResult:
    """Evaluate a point material at right Cauchy-Green tensors ``cmats`` (n, 9).

    ``load_increment`` (the step in the load parameter) and ``travel`` (the travel of
    the load programme per unit load parameter [mm]) scale the viscous regularisation of
    a foam with ``viscosity > 0`` (in MPa mm: per mm of travel); they are ignored
    otherwise.
    ``frozen`` evaluates a plastic material elastically about its plastic state ``ep_n``
    (the stiffness of elastic unloading, which sets the explicit stable time step):
    :func:`~forming.materials.kernels.foam_frozen_points`, no return mapping, and
    ``ep``, ``evp`` returned unchanged.
    ``tangent`` chooses the closed-form consistent tangent (default) or the central
    difference of the stress update with relative step ``h`` (13 updates per point;
    kept to verify the closed form).
    ``cells`` gives a damaging material (:mod:`forming.materials.fracture`) the inverse
    Jacobians of the cells at their centres, (cells, 9), and the number of points per
    cell, for its crack bands; without it every point lies in a unit cube. Its history
    is ``ep`` = ``[d, h, D, Y, e, 0]`` (damage, band width, dissipated energy density,
    energy release rate, eroded) and ``evp`` = kappa, the largest principal stress of the
    undamaged solid over E reached; it has the closed-form tangent only, and ``frozen``
    returns its history unchanged.
    """
    if tangent not in _TANGENTS:
        raise InputError("tangent", f"must be one of {sorted(_TANGENTS)}, got {tangent!r}")
    mode = _TANGENTS[tangent] if want_tangent else kernels.TANGENT_NONE
    k = material.kernel_data()
    n = cmats.shape[0]
    cm = np.ascontiguousarray(cmats, dtype=float)
    s = np.zeros((n, 6))
    d = np.zeros((n, 36)) if want_tangent else np.zeros((0, 36))
    if not k.plastic:
        nbad, worst = kernels.elastic_points(cm, k.cel, k.measure, s, d, mode, h)
        return PointResult(s, d if want_tangent else None, None, None, int(nbad), int(worst))
    ep_in = np.zeros((n, 6)) if ep_n is None else np.ascontiguousarray(ep_n)
    evp_in = np.zeros(n) if evp_n is None else np.ascontiguousarray(evp_n)
    ep_out, evp_out = ep_in.copy(), evp_in.copy()
    if k.damage:
        ginv, per_cell = (np.eye(3).reshape(1, 9), n) if cells is None else cells
        hist_out, kappa_out = np.zeros((n, 6)), np.zeros(n)
        props = k.props if frozen else _damage_props(material, k, load_increment, travel)
        nbad, worst = damage_points(cm, ep_in, evp_in, k.cel, k.measure, props,
                                    np.ascontiguousarray(ginv), max(int(per_cell), 1), s,
                                    d, hist_out, kappa_out, want_tangent)
        if not frozen:
            ep_out, evp_out = hist_out, kappa_out
            if cells is not None:
                _delete_elements(material, hist_out, int(per_cell))
        return PointResult(s, d if want_tangent else None, ep_out, evp_out, int(nbad),
                           int(worst))
    if frozen:  # elastic about the plastic state: no return mapping, state unchanged
        nbad, worst = kernels.foam_frozen_points(cm, ep_in, k.cel, k.measure, s, d,
                                                 mode, h)
        return PointResult(s, d if want_tangent else None, ep_out, evp_out, int(nbad),
                           int(worst))
    props = _props(material, k, load_increment, travel)
    nbad, worst = kernels.foam_points(
        cm, ep_in, evp_in, k.cel, k.measure, props, k.xs, k.ys, k.ds, s, d, ep_out, evp_out,
        mode, h,
    )
    return PointResult(s, d if want_tangent else None, ep_out, evp_out, int(nbad), int(worst))


def _damage_props(material: PointMaterial, k: KernelData, load_increment: float,
                  travel: float) -> np.ndarray:
    """A damaging material's parameters, with the step's share of its viscous lag."""
    eta = getattr(material, "viscosity", 0.0)
    if eta > 0.0 and load_increment > 0.0:
        w = load_increment * travel / eta  # the step's travel over the viscosity
        props = k.props.copy()
        props[DAMAGE_RATE] = w / (1.0 + w)
        return props
    return k.props


# the share of a cell's points eroded that erodes the whole cell, by ``element_deletion``
# (at least one point)
_DELETION_SHARE = {"first": 0.0, "half": 0.5}


def _delete_elements(material: PointMaterial, hist: np.ndarray, per_cell: int) -> None:
    """Erode whole cells by their eroded points (``element_deletion`` "first", "half")."""
    share = _DELETION_SHARE.get(getattr(material, "element_deletion", "all"))
    if per_cell > 1 and share is not None:
        _erode_whole_cells(hist, per_cell, share)


def _erode_whole_cells(hist: np.ndarray, per_cell: int, share: float) -> None:
    """Every point of a cell with at least ``share`` of its points eroded is eroded too.

    From the next step on. ``hist`` is the damage history ``[d, h, D, Y, eroded, 0]`` of
    whole cells in turn.
    """
    need = max(1, math.ceil(share * per_cell))
    hit = np.count_nonzero(hist[:, 4].reshape(-1, per_cell) > 0.0, axis=1) >= need
    hist[np.repeat(hit, per_cell), 4] = 1.0


_NO_TANGENT = np.zeros((0, 36))  # the stress-only kernels never write a tangent


def point_stress(material: PointMaterial, cmats: np.ndarray, ep_n: np.ndarray,
                 evp_n: np.ndarray, s_out: np.ndarray, ep_out: np.ndarray,
                 evp_out: np.ndarray, load_increment: float = 0.0,
                 travel: float = 1.0,
                 cells: tuple[np.ndarray, int] | None = None) -> tuple[int, int]:
    """The stress alone, into preallocated arrays (the explicit solver's increments).

    The same stress update as :func:`evaluate` without a tangent, bit for bit; for an
    elastic material the plastic arrays are ignored (they may be empty). A damaging
    material needs ``cells`` (as :func:`evaluate`'s: its crack bands).

    Returns:
        (number of points with a non-zero status, worst status).

    Raises:
        InputError: A damaging material without ``cells``.
    """
    k = material.kernel_data()
    if k.damage:
        if cells is None:
            raise InputError("material", "a fracturing solid's crack bands need the cells' "
                             "inverse Jacobians (point_stress(..., cells=...))")
        ginv, per_cell = cells
        nbad, worst = damage_points(cmats, ep_n, evp_n, k.cel, k.measure,
                                    _damage_props(material, k, load_increment, travel),
                                    ginv, max(int(per_cell), 1), s_out, _NO_TANGENT,
                                    ep_out, evp_out, False)
        _delete_elements(material, ep_out, int(per_cell))
        return int(nbad), int(worst)
    if not k.plastic:
        return kernels.elastic_points(cmats, k.cel, k.measure, s_out, _NO_TANGENT,
                                      kernels.TANGENT_NONE, 0.0)
    return kernels.foam_points(cmats, ep_n, evp_n, k.cel, k.measure,
                               _props(material, k, load_increment, travel), k.xs, k.ys, k.ds,
                               s_out, _NO_TANGENT, ep_out, evp_out, kernels.TANGENT_NONE,
                               0.0)


def _props(material: PointMaterial, k: KernelData, load_increment: float,
           travel: float) -> np.ndarray:
    """The kernel's parameters, with the viscosity per unit load parameter of the step."""
    eta = getattr(material, "viscosity", 0.0) / travel  # per unit load parameter
    if eta > 0.0 and load_increment > 0.0:
        props = k.props.copy()
        props[PROP_VISC] = eta / load_increment
        return props
    return k.props


def measure_code(name: str) -> int:
    """The kernels' code of a strain measure; :class:`InputError` if unknown."""
    if name not in _MEASURES:
        raise InputError("material.strain_measure",
                         f"must be one of {sorted(_MEASURES)}, got {name!r}")
    return _MEASURES[name]


def check_density(value: float | None, field: str = "material.density") -> None:
    """Raise :class:`InputError` unless ``value`` is None or a positive finite number."""
    if value is not None and not (isinstance(value, int | float) and math.isfinite(value)
                                  and value > 0):
        raise InputError(field, f"must be a positive mass density [t/mm^3], got {value!r}")


@dataclass(frozen=True)
class ElasticSolid:
    """Hyperelastic solid, quadratic in the Hencky (or Biot) strain. Carries no state.

    Attributes:
        elasticity: Isotropic or transversely isotropic elasticity.
        strain_measure: ``"hencky"`` (logarithmic), ``"biot"``, or ``"biot-hencky"``
            (Biot in principal extension, Hencky in principal compression).
        density: Mass density [tonne/mm^3] (explicit dynamics only; None: not given).
    """

    elasticity: Elasticity
    strain_measure: StrainMeasure = "hencky"
    density: float | None = None

    def __post_init__(self) -> None:
        measure_code(self.strain_measure)
        check_density(self.density)

    @property
    def plastic(self) -> bool:
        """An elastic solid has no plastic state."""
        return False

    @cached_property
    def _data(self) -> KernelData:
        empty = np.zeros(1)
        return KernelData(
            self.elasticity.stiffness(), measure_code(self.strain_measure), False,
            np.zeros(N_PROPS), empty, empty, empty,
        )

    def kernel_data(self) -> KernelData:
        """The arrays the point kernel needs."""
        return self._data


class HardeningTable(NamedTuple):
    """Hardening law ``pc(evp)`` derived from a uniaxial curve."""

    evp: np.ndarray  # volumetric plastic strain, compression positive
    pc: np.ndarray  # hydrostatic compression yield stress [MPa]
    slope: np.ndarray  # monotone-cubic slopes dpc/devp
    sigma_c: np.ndarray  # uniaxial yield stress (true) at each evp
    alpha: float
    pt: float


@dataclass(frozen=True)
class CrushableFoam:
    """Crushable foam with volumetric hardening (the Abaqus model), at finite strain.

    Yield ``sqrt(q^2 + alpha^2 (p - p0)^2) - B <= 0`` with ``p0 = (pc - pt)/2``,
    ``B = alpha (pc + pt)/2``, ``alpha = 3k / sqrt((3kt + k)(3 - k))``; flow potential
    ``sqrt(q^2 + 9/2 p^2)`` (zero plastic Poisson ratio); ``pc`` hardens with the
    volumetric plastic strain, from the nominal uniaxial compression ``curve``.

    Attributes:
        elasticity: Isotropic or transversely isotropic elasticity.
        curve: Nominal uniaxial compression curve; its linear part must match the
            elasticity's axial modulus.
        k: Ratio of initial uniaxial to hydrostatic compression yield stress, in (0, 3).
        kt: Ratio of hydrostatic tension to initial hydrostatic compression yield stress.
        strain_measure: ``"hencky"`` (logarithmic), ``"biot"``, or ``"biot-hencky"``
            (Biot in principal extension, Hencky in principal compression).
        viscosity: Viscous regularisation eta [MPa mm]: the return mapping solves
            ``f = eta * dgamma / ds`` with ``ds`` the step's travel of the tools [mm]
            (Duvaut-Lions overstress along the stroke, independent of the stroke's
            length), which keeps Newton on a unique path through softening; 0 (default)
            is rate-independent, as the paper's core.
        density: Mass density [tonne/mm^3] (explicit dynamics only; None: not given).
        elastic_band: A curve point whose plastic strain is below this fraction of its
            strain is on the elastic line (measured curves scatter about it); a smooth
            curve computed from a model (``forming calibrate``) can use a narrower band.
    """

    elasticity: Elasticity
    curve: CompressionCurve
    k: float = 1.1
    kt: float = 0.1
    strain_measure: StrainMeasure = "hencky"
    viscosity: float = 0.0
    density: float | None = None
    elastic_band: float = 0.05

    def __post_init__(self) -> None:
        measure_code(self.strain_measure)
        check_density(self.density)
        if not (0.0 < self.elastic_band < 1.0):
            raise InputError("material.elastic_band",
                             f"must lie in (0, 1), got {self.elastic_band!r}")
        if not (0.0 < self.k < 3.0):
            raise InputError("material.k", f"must lie in (0, 3), got {self.k!r}")
        if not (0.0 <= self.kt):
            raise InputError("material.kt", f"must be non-negative, got {self.kt!r}")
        if not (math.isfinite(self.viscosity) and self.viscosity >= 0.0):
            raise InputError("material.viscosity", f"must be >= 0, got {self.viscosity!r}")
        if abs(self.elasticity.lateral_poisson) > 1e-12:
            collective_warning(
                log,
                "crushable foam: the curve conversion assumes no lateral strain in the "
                "uniaxial test; elastic lateral Poisson ratio %g makes it approximate",
                self.elasticity.lateral_poisson,
            )
        _ = self.hardening  # validate the curve now, not at the first solve

    @property
    def plastic(self) -> bool:
        """The foam carries plastic state."""
        return True

    @cached_property
    def hardening(self) -> HardeningTable:
        """Convert the nominal curve to ``pc(evp)`` (see ``docs/theory.md``)."""
        m = measure_code(self.strain_measure)
        e = np.asarray(self.curve.strain, dtype=float)
        s = np.asarray(self.curve.stress, dtype=float)
        lam = 1.0 - e
        c = lam**2
        e_tot = np.array([kernels.strain_f(ci, m) for ci in c])  # negative
        kappa = np.array([2 * ci * kernels.strain_theta(ci, ci, m) / li
                          for ci, li in zip(c, lam, strict=True)])
        t = -s / kappa
        e_el = t / self.elasticity.axial_modulus
        evp = -(e_tot - e_el)
        band = self.elastic_band
        elastic = evp[1:] < band * np.abs(e_tot[1:])
        above = np.nonzero(evp[1:] < -band * np.abs(e_tot[1:]))[0]
        if above.size:
            i = int(above[0]) + 1
            raise InputError(
                "curve",
                f"point {i} (strain {e[i]:g}, stress {s[i]:g}) lies above the elastic line of "
                f"axial modulus {self.elasticity.axial_modulus:g} MPa; the modulus is too low "
                "for this curve (change both together)",
            )
        if not elastic[0]:
            raise InputError(
                "curve",
                f"point 1 (strain {e[1]:g}, stress {s[1]:g}) is not on the elastic line of "
                f"axial modulus {self.elasticity.axial_modulus:g} MPa; the curve must start "
                "with its linear region, matching the elasticity",
            )
        last_el = int(np.nonzero(elastic)[0].max()) + 1
        if not np.all(~elastic[last_el:]):
            raise InputError("curve",
                             f"the curve returns to its elastic line after point {last_el}")
        sig_c = np.concatenate([[s[last_el]], s[last_el + 1:]])
        evp_t = np.concatenate([[0.0], evp[last_el + 1:]])
        if np.any(np.diff(evp_t) <= 0):
            i = int(np.nonzero(np.diff(evp_t) <= 0)[0][0]) + last_el + 1
            raise InputError(
                "curve",
                f"at point {i} (strain {e[i]:g}) the curve rises at least as steeply as the "
                "elastic line "
                f"(axial modulus {self.elasticity.axial_modulus:g} MPa): its plastic strain "
                "would decrease, which hardening cannot represent (a fall, however steep, "
                "is fine)",
            )
        sc0 = sig_c[0]
        pc0 = sc0 / self.k
        pt = self.kt * pc0
        alpha = 3 * self.k / math.sqrt((3 * self.kt + self.k) * (3 - self.k))
        pc = sig_c * (sig_c * (1 / alpha**2 + 1 / 9) + pt / 3) / (pt + sig_c / 3)
        return HardeningTable(evp_t, pc, pchip_slopes(evp_t, pc), sig_c, alpha, pt)

    @cached_property
    def _data(self) -> KernelData:
        h = self.hardening
        props = np.zeros(N_PROPS)  # PROP_VISC: 0, set per increment by evaluate()
        props[PROP_ALPHA], props[PROP_PT] = h.alpha, h.pt
        return KernelData(
            self.elasticity.stiffness(), measure_code(self.strain_measure), True,
            props, h.evp, h.pc, h.slope,
        )

    def kernel_data(self) -> KernelData:
        """The arrays the point kernel needs."""
        return self._data


SolidMaterial = ElasticSolid | CrushableFoam
