"""Point drivers: the stress and difference tangent of every quadrature point.

For each point, :func:`_point_tensors` builds C and its 12 perturbations, which are
diagonalised as one batch (:func:`~.linalg.eig_sym3`) and sent through the stress
update; :func:`_tangent_column` forms the central differences. The entry points
:func:`elastic_points` and :func:`foam_points` allocate the scratch arrays once per
call (:func:`_new_work`) and run the allocation-free loop bodies.
"""

from __future__ import annotations

import numba
import numpy as np

from .common import STATUS_OK, _inner
from .curve import _hermite_slope_bound, hermite_eval
from .elastic import _elastic_update
from .foam import _foam_update
from .linalg import eig_sym3
from .mandel import _MI, _MJ, SQRT2

_NUPD = 13  # stress updates per point with the tangent: C and C +/- h in 6 directions


@_inner
def _point_tensors(cmats, ip, h_rel, n, cs):
    """Right Cauchy-Green tensors of the stress updates of point ``ip``.

    Update 0 is the symmetrised C; updates ``2j + 1`` and ``2j + 2`` perturb it so
    that the Green-Lagrange Mandel component j changes by ``+h`` and ``-h``, with
    ``h = h_rel min(1, min_a C_aa)``.

    Args:
        cmats: (n_points, 9) tensors, row-major.
        ip: Point index.
        h_rel: Perturbation size in Green-Lagrange strain (for C near I).
        n: Number of updates (1 or 13).
        cs: (>= n, 3, 3) output: the tensors.

    Returns:
        ``h``.
    """
    for a in range(3):
        for b in range(3):
            cs[0, a, b] = 0.5 * (cmats[ip, 3 * a + b] + cmats[ip, 3 * b + a])
    h = h_rel * min(1.0, min(cs[0, 0, 0], min(cs[0, 1, 1], cs[0, 2, 2])))
    for u in range(1, n):
        sign = 1.0 if u % 2 == 1 else -1.0
        for a in range(3):
            for b in range(3):
                cs[u, a, b] = cs[0, a, b] + sign * 0.0  # C +/- dC, with dC = 0 here
        j = (u - 1) // 2
        a = _MI[j]
        b = _MJ[j]
        if a == b:
            cs[u, a, a] = cs[0, a, a] + sign * (2.0 * h)
        else:
            d = sign * (2.0 * h / SQRT2)
            cs[u, a, b] = cs[0, a, b] + d
            cs[u, b, a] = cs[0, b, a] + d
    return h


@_inner
def _tangent_column(d_out, ip, j, s, sp, sm, okp, okm, h):
    """Write column ``j`` of the finite-difference tangent of point ``ip``.

    Central difference if both perturbed updates succeeded, else one-sided.

    Args:
        d_out: (n, 36) tangent (Mandel, row-major).
        ip: Point index.
        j: Column (perturbed Mandel component).
        s: Stress at C (6-vector).
        sp: Stress at the ``+h`` perturbation (6-vector).
        sm: Stress at the ``-h`` perturbation (6-vector).
        okp: Whether the ``+h`` update succeeded.
        okm: Whether the ``-h`` update succeeded.
        h: Perturbation size.
    """
    for i in range(6):
        if okp and okm:
            d_out[ip, 6 * i + j] = (sp[i] - sm[i]) / (2.0 * h)
        elif okp:
            d_out[ip, 6 * i + j] = (sp[i] - s[i]) / h
        else:
            d_out[ip, 6 * i + j] = (s[i] - sm[i]) / h


@numba.njit(cache=True)
def _new_work():
    """Scratch arrays of the point loops.

    Returns:
        (C of each update, diagonalised C, eigenvectors, Jacobi scratch (two flags,
        cosine and sine), Mandel rotation, ``cel @ rot``, eigenframe stiffness,
        augmented system of the return mapping, stress of each update, their
        success).
    """
    return (np.empty((_NUPD, 3, 3)), np.empty((_NUPD, 3, 3)), np.empty((_NUPD, 3, 3)),
            np.empty(_NUPD, dtype=np.bool_), np.empty(_NUPD, dtype=np.bool_),
            np.empty((_NUPD, 2)), np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)),
            np.empty((6, 7)), np.empty((_NUPD, 6)), np.empty(_NUPD, dtype=np.bool_))


@_inner
def _elastic_points(cmats, cel, measure, s_out, d_out, want_tangent, h_rel, work):
    """Body of :func:`elastic_points`, with its scratch arrays ``work``."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, _lu, s_upd, _ok = work
    nupd = _NUPD if want_tangent else 1
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        h = _point_tensors(cmats, ip, h_rel, nupd, cs)
        eig_sym3(cs, nupd, ms, qs, active, turn, rcs)
        for u in range(nupd):
            c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
            st, s = _elastic_update(c, qs[u], cel, measure, rot, cr, c_eig)
            if u == 0 and st != STATUS_OK:
                nbad += 1
                worst = max(worst, st)
                break
            for i in range(6):
                s_upd[u, i] = s[i]
        else:
            for i in range(6):
                s_out[ip, i] = s_upd[0, i]
            for j in range(nupd // 2):
                _tangent_column(d_out, ip, j, s_upd[0], s_upd[2 * j + 1], s_upd[2 * j + 2],
                                True, True, h)
    return nbad, worst


@numba.njit(cache=True)
def elastic_points(cmats, cel, measure, s_out, d_out, want_tangent, h_rel):
    """Stress and tangent of the elastic solid at every point (no state, no return map).

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (Mandel, row-major).
        want_tangent: Compute ``d_out``.
        h_rel: Perturbation size in Green-Lagrange strain.

    Returns:
        (number of points with a non-zero status, worst status).
    """
    return _elastic_points(cmats, cel, measure, s_out, d_out, want_tangent, h_rel,
                           _new_work())


@_inner
def _foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                 s_out, d_out, ep_out, evp_out, want_tangent, h_rel, work):
    """Body of :func:`foam_points`, with its scratch arrays ``work``."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, lu, s_upd, ok_upd = work
    pc_slope = _hermite_slope_bound(xs, ys, ds)
    nupd = _NUPD if want_tangent else 1
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        h = _point_tensors(cmats, ip, h_rel, nupd, cs)
        eig_sym3(cs, nupd, ms, qs, active, turn, rcs)
        epn = ep_n[ip]
        evpn = evp_n[ip]
        pc_n, _h = hermite_eval(evpn, xs, ys, ds)
        for u in range(nupd):
            c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
            st, s, ep, evp = _foam_update(c, qs[u], epn, evpn, pc_n, cel, measure, props, xs, ys,
                                          ds, pc_slope, rot, cr, c_eig, lu)
            if u == 0:
                if st != STATUS_OK:
                    nbad += 1
                    worst = max(worst, st)
                    break
                for i in range(6):
                    ep_out[ip, i] = ep[i]
                evp_out[ip] = evp
            ok_upd[u] = st == STATUS_OK
            for i in range(6):
                s_upd[u, i] = s[i]
        else:
            for i in range(6):
                s_out[ip, i] = s_upd[0, i]
            for j in range(nupd // 2):
                okp = ok_upd[2 * j + 1]
                okm = ok_upd[2 * j + 2]
                if not (okp or okm):  # both failed: elastic column
                    for u in range(2 * j + 1, 2 * j + 3):
                        c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
                        _st, s = _elastic_update(c, qs[u], cel, measure, rot, cr, c_eig)
                        for i in range(6):
                            s_upd[u, i] = s[i]
                    okp = okm = True
                _tangent_column(d_out, ip, j, s_upd[0], s_upd[2 * j + 1], s_upd[2 * j + 2],
                                okp, okm, h)
    return nbad, worst


@numba.njit(cache=True)
def foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                s_out, d_out, ep_out, evp_out, want_tangent, h_rel):
    """Stress, tangent and trial state of the crushable foam at every point.

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        ep_n: (n, 6) converged plastic strain.
        evp_n: (n,) converged volumetric plastic strain (compression positive).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        props: (N_PROPS,) parameters: ``PROP_ALPHA`` alpha, ``PROP_PT`` pt,
            ``PROP_VISC`` eta / dt (0 without viscous regularisation).
        xs: Hardening table abscissae (volumetric plastic strain).
        ys: Hardening table values pc [MPa].
        ds: Hermite slopes of the table.
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (Mandel, row-major).
        ep_out: (n, 6) new plastic strain (a trial, accepted on convergence).
        evp_out: (n,) new volumetric plastic strain.
        want_tangent: Compute ``d_out``.
        h_rel: Perturbation size in Green-Lagrange strain.

    Returns:
        (number of points with a non-zero status, worst status).
    """
    return _foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds, s_out, d_out,
                        ep_out, evp_out, want_tangent, h_rel, _new_work())
