"""Contact laws in UFL, written once for tool contacts and skin-core interfaces.

Both are augmented-Lagrangian laws at the surface nodes (docs/theory.md, sections 9
and 11): the normal pressure is the positive part of the augmented trial pressure, and
the tangential traction is a Coulomb return of a trial traction onto the friction cone.
"""

from __future__ import annotations

import ufl

_TINY = 1e-30  # keeps the norm's derivative finite at zero


def normal_pressure(trial):
    """Positive part of the augmented trial pressure ``lambda_N - eps g``.

    ``>=``: a node that just touches (``trial = 0``) counts as active, so a body
    resting on a tool is supported in the first Jacobian.
    """
    return ufl.conditional(ufl.ge(trial, 0.0), trial, 0.0)


def smoothed_pressure(trial, width):
    """Smoothed positive part ``(trial + sqrt(trial^2 + width^2)) / 2``.

    At ``trial = 0`` it leaves a pressure of ``width / 2``; far from zero it equals
    :func:`normal_pressure`.
    """
    return 0.5 * (trial + ufl.sqrt(trial * trial + width * width))


def tangent_projector(normal):
    """Projector ``I - n (x) n`` onto the tangent plane of a unit normal."""
    return ufl.Identity(3) - ufl.outer(normal, normal)


def coulomb_return(trial, limit, slack: float = 0.0):
    """Coulomb return: the tangential traction on the friction cone.

    ``trial`` inside the cone of radius ``limit``, else its projection onto the cone
    (slip in the direction of the trial traction).

    Args:
        trial: Trial tangential traction (UFL vector).
        limit: Radius of the friction cone, ``mu p`` (UFL scalar).
        slack: Added to the radius in the stick test only; a node that just touches,
            with zero pressure and zero trial shear, then sticks instead of slipping in
            a round-off direction.
    """
    size = ufl.sqrt(ufl.dot(trial, trial) + _TINY)
    radius = limit + slack if slack else limit
    return ufl.conditional(ufl.le(size, radius), trial, limit * trial / size)
