"""Linear elasticity in the generalised-strain space (Mandel 6x6 stiffness matrices)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from forming.errors import InputError


def _check_positive(field: str, value: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise InputError(field, f"must be a positive number, got {value!r}")


def _unit(field: str, v: tuple[float, float, float]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0:
        raise InputError(field, f"must be a non-zero 3-vector, got {v!r}")
    return a / np.linalg.norm(a)


def frame_with_axis(axis: np.ndarray) -> np.ndarray:
    """Orthonormal frame (columns) whose third vector is ``axis``."""
    e3 = axis / np.linalg.norm(axis)
    trial = np.array([1.0, 0.0, 0.0]) if abs(e3[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = trial - np.dot(trial, e3) * e3
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    return np.column_stack([e1, e2, e3])


def mandel_rotation_np(q: np.ndarray) -> np.ndarray:
    """NumPy twin of :func:`forming.materials.kernels.mandel_rotation`."""
    from forming.materials.kernels import mandel_rotation

    return mandel_rotation(np.ascontiguousarray(q, dtype=float))


@dataclass(frozen=True)
class IsotropicElasticity:
    """Isotropic elasticity (the parity option with Abaqus's crushable foam).

    Attributes:
        E: Young's modulus [MPa].
        nu: Poisson's ratio.
    """

    E: float
    nu: float = 0.0

    def __post_init__(self) -> None:
        _check_positive("elasticity.E", self.E)
        if not (-1.0 < self.nu < 0.5):
            raise InputError("elasticity.nu", f"must lie in (-1, 0.5), got {self.nu!r}")

    @property
    def axial_modulus(self) -> float:
        """Uniaxial modulus along the crushing direction."""
        return self.E

    @property
    def lateral_poisson(self) -> float:
        """Lateral contraction ratio under axial load."""
        return self.nu

    def stiffness(self) -> np.ndarray:
        """Mandel stiffness matrix in the global frame."""
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        mu = self.E / (2 * (1 + self.nu))
        c = 2 * mu * np.eye(6)
        c[:3, :3] += lam
        return c


@dataclass(frozen=True)
class TransverselyIsotropicElasticity:
    """Transversely isotropic elasticity about ``axis`` (the honeycomb cell axis).

    Attributes:
        E_through: Modulus along the axis (through-thickness) [MPa].
        E_inplane: Modulus in the plane normal to the axis [MPa].
        G_through: Transverse shear modulus (planes containing the axis) [MPa].
        nu_inplane: In-plane Poisson's ratio.
        nu_through: In-plane contraction per unit through-thickness strain.
        axis: Cell axis in the reference configuration.
    """

    E_through: float
    E_inplane: float
    G_through: float
    nu_inplane: float = 0.0
    nu_through: float = 0.0
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        _check_positive("elasticity.E_through", self.E_through)
        _check_positive("elasticity.E_inplane", self.E_inplane)
        _check_positive("elasticity.G_through", self.G_through)
        _unit("elasticity.axis", self.axis)
        if not (-1.0 < self.nu_inplane < 1.0):
            raise InputError("elasticity.nu_inplane", f"must lie in (-1, 1), got {self.nu_inplane}")
        if np.any(np.linalg.eigvalsh(self._local_compliance()) <= 0):
            raise InputError(
                "elasticity.nu_through",
                f"nu_through={self.nu_through} with nu_inplane={self.nu_inplane} "
                "gives a stiffness that is not positive definite",
            )

    @property
    def axial_modulus(self) -> float:
        """Uniaxial modulus along the crushing direction (the axis)."""
        return self.E_through

    @property
    def lateral_poisson(self) -> float:
        """Lateral contraction ratio under axial load."""
        return self.nu_through

    def _local_compliance(self) -> np.ndarray:
        ep, et = self.E_inplane, self.E_through
        gp = ep / (2 * (1 + self.nu_inplane))
        s = np.zeros((6, 6))
        s[0, 0] = s[1, 1] = 1 / ep
        s[0, 1] = s[1, 0] = -self.nu_inplane / ep
        s[0, 2] = s[2, 0] = s[1, 2] = s[2, 1] = -self.nu_through / et
        s[2, 2] = 1 / et
        s[3, 3] = s[4, 4] = 1 / (2 * self.G_through)
        s[5, 5] = 1 / (2 * gp)
        return s

    def stiffness(self) -> np.ndarray:
        """Mandel stiffness matrix in the global frame."""
        c_local = np.linalg.inv(self._local_compliance())
        r = mandel_rotation_np(frame_with_axis(np.asarray(self.axis, dtype=float)))
        return r @ c_local @ r.T


Elasticity = IsotropicElasticity | TransverselyIsotropicElasticity
