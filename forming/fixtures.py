"""Kinematics of the fabric test fixtures.

The pin-jointed picture frame and the pin-jointed bias-extension specimen
(material-data.md, docs/theory.md "Fabric skins").
"""

from __future__ import annotations

import math

import numpy as np


def frame_gradient(gamma: float) -> np.ndarray:
    """Displacement gradient H = F - I of the pin-jointed frame at shear ``gamma`` [rad].

    The fibres along x and y turn towards each other by gamma/2 each, without stretching.
    """
    c, s = math.cos(gamma / 2), math.sin(gamma / 2)
    return np.array([[c - 1.0, s, 0.0], [s, c - 1.0, 0.0], [0.0, 0.0, 0.0]])


def frame_gradient_rate(gamma: float) -> np.ndarray:
    """d(F)/d(gamma) of :func:`frame_gradient`."""
    c, s = math.cos(gamma / 2), math.sin(gamma / 2)
    return 0.5 * np.array([[-s, c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]])


def bias_extension_shear(D: float, d: float) -> float:
    """Central-zone shear angle [rad] of a pin-jointed bias specimen at extension ``d``.

    ``gamma = pi/2 - 2 acos((D + d) / (sqrt(2) D))``, with ``D`` the free length minus
    the width.
    """
    return math.pi / 2 - 2 * math.acos(min((D + d) / (math.sqrt(2) * D), 1.0))
