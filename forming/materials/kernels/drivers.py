"""Point drivers: the stress and tangent of every quadrature point.

The tangent is the closed form of :mod:`.closed` (``tangent=TANGENT_CLOSED``, one
stress update per point), or the central difference of the stress update
(``TANGENT_DIFFERENCE``, kept to verify it): :func:`.tangent._point_tensors` builds
C and its 12 perturbations, which are diagonalised as one batch
(:func:`.linalg.eig_sym3`) and sent through the stress update; :mod:`.tangent`
forms the difference quotients. The stress alone (``TANGENT_NONE``: a residual, an
explicit increment) takes the batched path of the closed form and skips the tangent.
The entry points :func:`elastic_points`,
:func:`foam_points` and :func:`foam_frozen_points` (the foam elastic about its
plastic state) allocate the scratch arrays once per call (:func:`_new_work`) and
run the allocation-free loop bodies.
"""

from __future__ import annotations

import numba
import numpy as np

from .closed import elastic_tangent, foam_plastic_tangent
from .common import STATUS_INVERTED, STATUS_OK, STATUS_RETURN_MAP, _inner
from .curve import _hermite_slope_bound, hermite_eval
from .elastic import _elastic_state, _elastic_update
from .foam import _foam_frozen_update, _foam_return, _foam_update
from .linalg import eig_sym3
from .mandel import _mul6, _mv6
from .tangent import _NUPD, _foam_tangent, _point_tensors, _tangent_column

_BATCH = 16  # points diagonalised together by the closed-form drivers (>= _NUPD)
TANGENT_NONE = 0
TANGENT_CLOSED = 1  # closed form (:mod:`.closed`); ``True`` means this one
TANGENT_DIFFERENCE = 2  # central difference of the stress update (13 updates per point)


@numba.njit(cache=True)
def _new_work():
    """Scratch arrays of the point loops.

    Returns:
        (C of each update, diagonalised C, eigenvectors, Jacobi scratch (two flags,
        cosine and sine), Mandel rotation, ``cel @ rot``, eigenframe stiffness,
        augmented system of the return mapping, stress of each update, their
        success).
    """
    return (np.empty((_BATCH, 3, 3)), np.empty((_BATCH, 3, 3)), np.empty((_BATCH, 3, 3)),
            np.empty(_BATCH, dtype=np.bool_), np.empty(_BATCH, dtype=np.bool_),
            np.empty((_BATCH, 2)), np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)),
            np.empty((6, 10)), np.empty((_NUPD, 6)), np.empty(_NUPD, dtype=np.bool_))


@numba.njit(cache=True)
def _new_tangent_work():
    """Scratch arrays of the closed-form tangent.

    Returns:
        (scratch of :func:`.closed.geometric_terms`: second divided differences and
        five 3x3 tensors, ``G_S``, ``G_K``; then two 6x6 matrices and the 7x13 local
        system).
    """
    geo = (np.empty((3, 3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)),
           np.empty((3, 3)), np.empty((3, 3)), np.empty((6, 6)), np.empty((6, 6)))
    return geo, np.empty((6, 6)), np.empty((6, 6)), np.empty((7, 13))


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


@_inner
def _load_batch(cmats, start, cs):
    """Diagonalisation input for points ``start, start + 1, ...``: their symmetrised C.

    Args:
        cmats: (n, 9) tensors, row-major.
        start: First point of the batch.
        cs: (_BATCH, 3, 3) output.

    Returns:
        The number of points in the batch (at most ``_BATCH``).
    """
    nb = min(_BATCH, cmats.shape[0] - start)
    for k in range(nb):
        ip = start + k
        for a in range(3):
            for b in range(3):
                cs[k, a, b] = 0.5 * (cmats[ip, 3 * a + b] + cmats[ip, 3 * b + a])
    return nb


@_inner
def _batch_eigen(cmats, ip, cs, ms, qs, active, turn, rcs):
    """Eigenvalues of C at point ``ip``; diagonalises its batch when ``ip`` starts one.

    The points of a batch are diagonalised together (:func:`.linalg.eig_sym3`), so the
    latencies of their Jacobi rotations overlap.

    Returns:
        (the point's index in the batch, its eigenvalues as a 3-tuple); the
        eigenvectors are ``qs[index]``.
    """
    k = ip % _BATCH
    if k == 0:
        eig_sym3(cs, _load_batch(cmats, ip, cs), ms, qs, active, turn, rcs)
    return k, (ms[k, 0, 0], ms[k, 1, 1], ms[k, 2, 2])


@_inner
def _elastic_points_closed(cmats, cel, measure, s_out, d_out, want_tangent, work, twork):
    """Body of :func:`elastic_points` with the closed-form tangent (or none)."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, _lu, _s, _ok = work
    geo, mt, tmp, _sys = twork
    nbad = 0
    for ip in range(cmats.shape[0]):
        k, c = _batch_eigen(cmats, ip, cs, ms, qs, active, turn, rcs)
        ok, s_fac, t = _elastic_state(c, qs[k], cel, measure, rot, cr, c_eig, 6)
        if not ok:
            nbad += 1
            continue
        s = _mv6(rot, _mul6(s_fac, t))
        for i in range(6):
            s_out[ip, i] = s[i]
        if want_tangent:
            elastic_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, geo, mt, tmp)
    return nbad, STATUS_INVERTED if nbad else STATUS_OK


@numba.njit(cache=True)
def elastic_points(cmats, cel, measure, s_out, d_out, tangent, h_rel):
    """Stress and tangent of the elastic solid at every point (no state, no return map).

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (Mandel, row-major).
        tangent: ``TANGENT_NONE`` (``d_out`` untouched), ``TANGENT_CLOSED`` or
            ``TANGENT_DIFFERENCE``.
        h_rel: Perturbation size in Green-Lagrange strain (difference tangent).

    Returns:
        (number of points with a non-zero status, worst status).
    """
    if tangent != TANGENT_DIFFERENCE:  # closed form, or the stress alone
        return _elastic_points_closed(cmats, cel, measure, s_out, d_out,
                                      tangent == TANGENT_CLOSED, _new_work(),
                                      _new_tangent_work())
    return _elastic_points(cmats, cel, measure, s_out, d_out, tangent == TANGENT_DIFFERENCE,
                           h_rel, _new_work())


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
            _foam_tangent(d_out, ip, nupd, s_upd, ok_upd, ms, qs, cel, measure, rot, cr, c_eig, h)
    return nbad, worst


@_inner
def _foam_points_closed(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                        s_out, d_out, ep_out, evp_out, want_tangent, work, twork):
    """Body of :func:`foam_points` with the closed-form tangent (or none)."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, lu, _s, _ok = work
    geo, mt, tmp, sysm = twork
    pc_slope = _hermite_slope_bound(xs, ys, ds)
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        k, c = _batch_eigen(cmats, ip, cs, ms, qs, active, turn, rcs)
        evpn = evp_n[ip]
        pc_n, _h = hermite_eval(evpn, xs, ys, ds)
        st, s_fac, k_fac, t, sig, mu, ep, evp = _foam_return(
            c, qs[k], ep_n[ip], evpn, pc_n, cel, measure, props, xs, ys, ds, pc_slope, rot, cr,
            c_eig, lu)
        if st != STATUS_OK:
            nbad += 1
            worst = max(worst, st)
            continue
        for i in range(6):
            ep_out[ip, i] = ep[i]
        evp_out[ip] = evp
        s = _mv6(rot, _mul6(s_fac, t))
        for i in range(6):
            s_out[ip, i] = s[i]
        if not want_tangent:
            continue
        if mu == 0.0:
            elastic_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, geo, mt, tmp)
        elif not foam_plastic_tangent(d_out, ip, c, t, sig, mu, evp, s_fac, k_fac, c_eig, rot,
                                      measure, props, xs, ys, ds, geo, mt, tmp, sysm):
            nbad += 1
            worst = max(worst, STATUS_RETURN_MAP)
    return nbad, worst


@numba.njit(cache=True)
def foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds,
                s_out, d_out, ep_out, evp_out, tangent, h_rel):
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
        tangent: ``TANGENT_NONE`` (``d_out`` untouched), ``TANGENT_CLOSED`` or
            ``TANGENT_DIFFERENCE``.
        h_rel: Perturbation size in Green-Lagrange strain (difference tangent).

    Returns:
        (number of points with a non-zero status, worst status).
    """
    if tangent != TANGENT_DIFFERENCE:  # closed form, or the stress alone
        return _foam_points_closed(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds, s_out,
                                   d_out, ep_out, evp_out, tangent == TANGENT_CLOSED,
                                   _new_work(), _new_tangent_work())
    return _foam_points(cmats, ep_n, evp_n, cel, measure, props, xs, ys, ds, s_out, d_out,
                        ep_out, evp_out, tangent == TANGENT_DIFFERENCE, h_rel, _new_work())


@_inner
def _foam_frozen_points(cmats, ep_n, cel, measure, s_out, d_out, want_tangent, h_rel, work):
    """Body of :func:`foam_frozen_points`, with its scratch arrays ``work``."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, _lu, s_upd, ok_upd = work
    nupd = _NUPD if want_tangent else 1
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        h = _point_tensors(cmats, ip, h_rel, nupd, cs)
        eig_sym3(cs, nupd, ms, qs, active, turn, rcs)
        epn = ep_n[ip]
        for u in range(nupd):
            c = (ms[u, 0, 0], ms[u, 1, 1], ms[u, 2, 2])
            st, s, _sf, _t = _foam_frozen_update(c, qs[u], epn, cel, measure, rot, cr, c_eig)
            if u == 0 and st != STATUS_OK:
                nbad += 1
                worst = max(worst, st)
                break
            ok_upd[u] = st == STATUS_OK
            for i in range(6):
                s_upd[u, i] = s[i]
        else:
            for i in range(6):
                s_out[ip, i] = s_upd[0, i]
            _foam_tangent(d_out, ip, nupd, s_upd, ok_upd, ms, qs, cel, measure, rot, cr, c_eig, h)
    return nbad, worst


@_inner
def _foam_frozen_points_closed(cmats, ep_n, cel, measure, s_out, d_out, want_tangent, work,
                               twork):
    """Body of :func:`foam_frozen_points` with the closed-form tangent (or none)."""
    cs, ms, qs, active, turn, rcs, rot, cr, c_eig, _lu, _s, _ok = work
    geo, mt, tmp, _sys = twork
    nbad = 0
    worst = 0
    for ip in range(cmats.shape[0]):
        k, c = _batch_eigen(cmats, ip, cs, ms, qs, active, turn, rcs)
        st, s, s_fac, t = _foam_frozen_update(c, qs[k], ep_n[ip], cel, measure, rot, cr, c_eig)
        if st != STATUS_OK:
            nbad += 1
            worst = max(worst, st)
            continue
        for i in range(6):
            s_out[ip, i] = s[i]
        if want_tangent:
            elastic_tangent(d_out, ip, c, t, s_fac, c_eig, rot, measure, geo, mt, tmp)
    return nbad, worst


@numba.njit(cache=True)
def foam_frozen_points(cmats, ep_n, cel, measure, s_out, d_out, tangent, h_rel):
    """Stress and tangent of the crushable foam with its plastic state frozen.

    Every update is elastic about the converged plastic strain ``ep_n`` (no yield
    check, no return mapping): the response of elastic unloading, whose stiffness
    sets the explicit stable time step. The plastic state is not changed.

    Args:
        cmats: (n, 9) right Cauchy-Green tensors, row-major.
        ep_n: (n, 6) converged plastic strain.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        s_out: (n, 6) second Piola-Kirchhoff stress (Mandel).
        d_out: (n, 36) tangent dS/dE_GL (Mandel, row-major).
        tangent: ``TANGENT_NONE`` (``d_out`` untouched), ``TANGENT_CLOSED`` or
            ``TANGENT_DIFFERENCE``.
        h_rel: Perturbation size in Green-Lagrange strain (difference tangent).

    Returns:
        (number of points with a non-zero status, worst status).
    """
    if tangent != TANGENT_DIFFERENCE:  # closed form, or the stress alone
        return _foam_frozen_points_closed(cmats, ep_n, cel, measure, s_out, d_out,
                                          tangent == TANGENT_CLOSED, _new_work(),
                                          _new_tangent_work())
    return _foam_frozen_points(cmats, ep_n, cel, measure, s_out, d_out,
                               tangent == TANGENT_DIFFERENCE, h_rel, _new_work())
