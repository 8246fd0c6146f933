"""Seth-Hill strain measures: principal strains, their divided differences, the kinematics.

For an eigenvalue ``c`` of C the principal strain is ``f(c)`` (:func:`strain_f`:
Hencky, Biot, or Biot in extension and Hencky in compression); the divided
differences ``theta_ab`` (:func:`strain_theta`) map the stress ``T`` to ``S``, and
``kappa_ab`` (:func:`_kappa`) map it to the rotated Cauchy stress.
:func:`_kinematics` gathers all three, as Mandel 6-tuples, in the eigenframe of C.
"""

from __future__ import annotations

import math

from .common import _inner
from .mandel import _ZERO6

MEASURE_HENCKY = 0
MEASURE_BIOT = 1
MEASURE_BIOT_HENCKY = 2  # Biot for principal stretches > 1, Hencky below (C1 at 1)


@_inner
def strain_f(c, measure):
    """Principal generalised strain for a principal value ``c`` of C.

    Args:
        c: Eigenvalue of C (positive).
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).

    Returns:
        ``f(c)``.
    """
    if measure == MEASURE_HENCKY or (measure == MEASURE_BIOT_HENCKY and c < 1.0):
        return 0.5 * math.log(c)
    return math.sqrt(c) - 1.0


@_inner
def _theta_hencky(ca, cb):
    """Divided difference of ``f(c) = ln(c)/2``, by a series for close arguments.

    Args:
        ca: First eigenvalue of C.
        cb: Second eigenvalue of C.

    Returns:
        ``(f(ca) - f(cb)) / (ca - cb)``.
    """
    x = ca / cb - 1.0
    if abs(x) < 1e-5:
        return (1.0 - 0.5 * x + x * x / 3.0 - 0.25 * x * x * x) / (2.0 * cb)
    return math.log1p(x) / x / (2.0 * cb)


@_inner
def strain_theta(ca, cb, measure):
    """Divided difference ``(f(ca) - f(cb)) / (ca - cb)``, ``f'(ca)`` in the limit.

    Args:
        ca: First eigenvalue of C.
        cb: Second eigenvalue of C.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).

    Returns:
        ``theta_ab``.
    """
    if measure == MEASURE_BIOT:
        return 1.0 / (math.sqrt(ca) + math.sqrt(cb))
    if measure == MEASURE_HENCKY:
        return _theta_hencky(ca, cb)
    if ca >= 1.0 and cb >= 1.0:
        return 1.0 / (math.sqrt(ca) + math.sqrt(cb))
    if ca < 1.0 and cb < 1.0:
        return _theta_hencky(ca, cb)
    if abs(ca - cb) < 1e-7:
        return 0.5  # f'(1) of both branches
    return (strain_f(ca, measure) - strain_f(cb, measure)) / (ca - cb)


@_inner
def _kappa(ca, cb, theta, jac):
    """Sigma-scaling ``kappa_ab = 2 sqrt(ca cb) theta_ab / J`` of one Mandel component.

    Args:
        ca: First eigenvalue of C of the component.
        cb: Second eigenvalue of C of the component.
        theta: ``theta_ab``.
        jac: ``J = sqrt(det C)``.

    Returns:
        ``kappa_ab``.
    """
    return 2.0 * math.sqrt(ca * cb) * theta / jac


@_inner
def _kinematics(c, measure, with_kappa):
    """Eigen-frame kinematics of C: strain, S- and sigma-scalings.

    Args:
        c: The eigenvalues of C (3-tuple).
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        with_kappa: Compute the sigma-scalings (else returned as zeros).

    Returns:
        (C positive definite, strain, S-scalings ``2 theta_ab``, sigma-scalings
        ``kappa_ab``), the last three as Mandel 6-tuples in the eigenframe (zero if
        C is not positive definite).
    """
    c0, c1, c2 = c
    if not (c0 > 0.0 and c1 > 0.0 and c2 > 0.0):
        return False, _ZERO6, _ZERO6, _ZERO6
    e_eig = (strain_f(c0, measure), strain_f(c1, measure), strain_f(c2, measure), 0.0, 0.0, 0.0)
    # Mandel component (a, b): (0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)
    th0 = strain_theta(c0, c0, measure)
    th1 = strain_theta(c1, c1, measure)
    th2 = strain_theta(c2, c2, measure)
    th3 = strain_theta(c1, c2, measure)
    th4 = strain_theta(c0, c2, measure)
    th5 = strain_theta(c0, c1, measure)
    s_fac = (2.0 * th0, 2.0 * th1, 2.0 * th2, 2.0 * th3, 2.0 * th4, 2.0 * th5)
    if not with_kappa:
        return True, e_eig, s_fac, _ZERO6
    jac = math.sqrt(c0 * c1 * c2)
    k_fac = (_kappa(c0, c0, th0, jac), _kappa(c1, c1, th1, jac), _kappa(c2, c2, th2, jac),
             _kappa(c1, c2, th3, jac), _kappa(c0, c2, th4, jac), _kappa(c0, c1, th5, jac))
    return True, e_eig, s_fac, k_fac
