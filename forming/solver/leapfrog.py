"""Compiled per-body passes of the explicit solver's increment.

An increment touches each body's vectors a few times: it keeps the state it starts
from, advances velocity and displacement (the leapfrog), sets the prescribed dofs'
velocities, sums the works of the energy ledger and forms the acceleration. As NumPy
expressions these are some thirty array operations per body and increment, whose
call overhead does not divide over the ranks; here they are four loops. The sums run
over the rank's owned dofs; the updates over owned and ghost dofs alike, so that a
ghost's motion is its owner's without a scatter.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True)
def advance(u, v, a, f_int, f_all, u0, f0, r0, v0, n_owned, h, dt):
    """Keep the start of the increment, then ``v += h a`` and ``u += dt v``.

    Args:
        u: Displacement (owned and ghost dofs), updated.
        v: Velocity at the half step, updated.
        a: Acceleration.
        f_int: Internal forces.
        f_all: Full residual.
        u0: Output: ``u`` before the increment.
        f0: Output: ``f_int`` at the owned dofs.
        r0: Output: ``f_all`` at the owned dofs.
        v0: Output: ``v`` before the increment.
        n_owned: Owned dofs (first in every array).
        h: The velocity's step (``dt``, or ``dt / 2`` from rest).
        dt: The increment.
    """
    for i in range(n_owned):
        f0[i] = f_int[i]
        r0[i] = f_all[i]
    for i in range(u.shape[0]):
        u0[i] = u[i]
        v0[i] = v[i]
        v[i] += h * a[i]
        u[i] += dt * v[i]


@numba.njit(cache=True)
def prescribed_velocity(u, u0, v, dofs, dt):
    """The velocity of each prescribed dof over the increment, ``(u - u0) / dt``."""
    for i in dofs:
        v[i] = (u[i] - u0[i]) / dt


@numba.njit(cache=True)
def works(u, u0, f_int, f0, f_all, r0, fixed, m, v, v0, alpha, n_owned, du):
    """One body's works over the increment at this rank's owned dofs (trapezoidal rule).

    Args:
        u: Displacement at the end of the increment.
        u0: Displacement at its start.
        f_int: Internal forces at the end.
        f0: Internal forces at the start (owned).
        f_all: Full residual at the end.
        r0: Full residual at the start (owned).
        fixed: Whether each dof is prescribed.
        m: Lumped mass per dof.
        v: Velocity at the end.
        v0: Velocity at the start.
        alpha: Mass damping coefficient [1/s] (0: none).
        n_owned: Owned dofs.
        du: Output: the displacement increment at the owned dofs.

    Returns:
        (internal work, ``-R . du`` over the free dofs plus the kinetic energy the
        supports gave the prescribed ones, work of the mass damping's force).
    """
    w_int = w_ext = w_damp = 0.0
    for i in range(n_owned):
        d = u[i] - u0[i]
        du[i] = d
        w_int += 0.5 * (f0[i] + f_int[i]) * d
        if fixed[i]:
            w_ext += 0.5 * m[i] * (v[i] * v[i] - v0[i] * v0[i])
        else:
            w_ext -= 0.5 * (r0[i] + f_all[i]) * d
            if alpha > 0.0:
                w_damp += alpha * m[i] * v0[i] * d
    return w_int, w_ext, w_damp


@numba.njit(cache=True)
def accelerate(f_all, m, v, alpha, fixed, a):
    """Acceleration ``a = -R / m - alpha v``, zero at the prescribed dofs."""
    for i in range(a.shape[0]):
        a[i] = 0.0 if fixed[i] else -f_all[i] / m[i] - alpha * v[i]
