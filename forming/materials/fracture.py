"""An elastic solid that fractures: isotropic damage regularised by the crack band.

The cell walls of the paper's honeycomb (Table 1: fracture strain 0.067). The law and
its regularisation are in :mod:`forming.materials.kernels.damage` and
``docs/theory.md``; the mesh-independence test is in ``tests/test_fracture.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np

from forming.errors import InputError
from forming.materials.elasticity import IsotropicElasticity
from forming.materials.kernels.damage import (
    DAMAGE_DELETE,
    DAMAGE_DMAX,
    DAMAGE_EPS_F,
    DAMAGE_ERODE,
    DAMAGE_GF,
    DAMAGE_RATE,
    DAMAGE_SIGMA_F,
    N_DAMAGE_PROPS,
)
from forming.materials.solids import KernelData, StrainMeasure, check_density, measure_code


@dataclass(frozen=True)
class FracturingSolid:
    """Elastic solid that fractures: isotropic damage with a crack-band regularisation.

    Its stiffness degrades once its largest principal stress passes E ``fracture_strain``,
    dissipating ``fracture_energy`` per unit crack area whatever the element size.

    Attributes:
        elasticity: Isotropic elasticity.
        fracture_strain: Largest principal strain at the onset of damage (> 0).
        fracture_energy: G_f [N/mm = kJ/m^2] per unit crack area (> 0).
        max_damage: Damage at which softening stops, in (0, 1): the residual
            stiffness ``1 - max_damage`` keeps an implicit system regular.
        erosion: Erode a point once its band is spent (no stress, no shape check),
            as an explicit code deletes failed elements. An eroded element's inner
            nodes are then held only by a scene's stabilisation.
        deletion_strain: Erode a point, from the next step on, once its largest
            principal strain in magnitude (Hencky; compression counts) reaches this
            value, damaged or not: element deletion at a failure strain, as the paper's
            dummy materials (Table 3). None: no deletion (``erosion`` alone erodes spent
            bands). Explicit runs: an eroded region has no stiffness left.
        element_deletion: When an element erodes: ``"all"`` (default) once every one of
            its points has, ``"first"`` with its first, the rule of explicit codes'
            solid element deletion (Abaqus/Explicit's and LS-DYNA's default). With
            ``"all"`` a cracked element whose other points still carry stress stays, and
            can stretch far; with ``"first"`` it goes, and the crack opens by a whole
            element. ``"half"``: once at least half of its points have, LS-DYNA's
            default for its fully integrated and higher-order solids (``VOLFRAC`` 0.5 of
            ``*MAT_ADD_EROSION``; here half of the points by count, not by volume): a
            crack that has run through half an element takes it, one spent corner does
            not. One-point (reduced) elements: the same under every rule.
        viscosity: Viscous regularisation of the damage [mm of the tools' travel]: the
            damage follows its rate-independent value with this lag (0: none, the
            default). Implicit runs only; it needs something in the scene to move.
        strain_measure: ``"hencky"`` (default), ``"biot"`` or ``"biot-hencky"``.
        density: Mass density [tonne/mm^3] (explicit dynamics only; None: not given).
    """

    elasticity: IsotropicElasticity
    fracture_strain: float = 0.067
    fracture_energy: float = 7.4
    max_damage: float = 0.99
    erosion: bool = False
    deletion_strain: float | None = None
    element_deletion: Literal["all", "first", "half"] = "all"
    viscosity: float = 0.0
    strain_measure: StrainMeasure = "hencky"
    density: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.elasticity, IsotropicElasticity):
            raise InputError("material.elasticity", "a fracturing solid is isotropic: give "
                             f"IsotropicElasticity, got {type(self.elasticity).__name__}")
        if not (math.isfinite(self.viscosity) and self.viscosity >= 0.0):
            raise InputError("material.viscosity", f"must be >= 0, got {self.viscosity!r}")
        for name in ("fracture_strain", "fracture_energy"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"material.{name}", f"must be a positive number, got {v!r}")
        d = self.deletion_strain
        if d is not None and not (isinstance(d, int | float) and math.isfinite(d) and d > 0):
            raise InputError("material.deletion_strain",
                             f"must be a positive number or None, got {d!r}")
        if self.element_deletion not in ("all", "first", "half"):
            raise InputError("material.element_deletion", "must be 'all', 'first' or "
                             f"'half', got {self.element_deletion!r}")
        if not (0.0 < self.max_damage < 1.0):
            raise InputError("material.max_damage",
                             f"must lie in (0, 1), got {self.max_damage!r}")
        measure_code(self.strain_measure)
        check_density(self.density)

    @property
    def plastic(self) -> bool:
        """The solid carries history (its damage), like a plastic one."""
        return True

    @property
    def damaging(self) -> bool:
        """Whether the history is damage (not plastic strain)."""
        return True

    @property
    def erodes(self) -> bool:
        """Whether points can erode (spent bands with ``erosion``, or a deletion strain)."""
        return self.erosion or self.deletion_strain is not None

    @property
    def fracture_stress(self) -> float:
        """Uniaxial stress at the onset of damage [MPa]."""
        return self.elasticity.E * self.fracture_strain

    @property
    def widest_band(self) -> float:
        """Widest crack band [mm] that softens without snap-back: ``2 G_f/(sigma_f eps_f)``.

        Wider elements get the steepest softening and dissipate more than ``G_f``.
        """
        return 2.0 * self.fracture_energy / (self.fracture_stress * self.fracture_strain)

    @cached_property
    def _data(self) -> KernelData:
        props = np.zeros(N_DAMAGE_PROPS)
        props[DAMAGE_EPS_F] = self.fracture_strain
        props[DAMAGE_SIGMA_F] = self.fracture_stress
        props[DAMAGE_GF] = self.fracture_energy
        props[DAMAGE_DMAX] = self.max_damage
        props[DAMAGE_ERODE] = 1.0 if self.erosion else 0.0
        props[DAMAGE_RATE] = 1.0  # rate-independent; evaluate() sets a step's share
        props[DAMAGE_DELETE] = self.deletion_strain or 0.0
        empty = np.zeros(1)
        return KernelData(self.elasticity.stiffness(), measure_code(self.strain_measure), True,
                          props, empty, empty, empty, damage=True)

    def kernel_data(self) -> KernelData:
        """The arrays the point kernel needs."""
        return self._data
