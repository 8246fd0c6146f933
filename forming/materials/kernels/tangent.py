"""Difference tangent: the perturbed tensors of a point and the columns of ``dS/dE_GL``.

The tangent takes 13 stress updates per point (:data:`_NUPD`): C, and C perturbed by
``+/-h`` in each Green-Lagrange Mandel component (:func:`_point_tensors`). Each
column of the tangent is the central difference of two of them, one-sided if one
failed (:func:`_tangent_column`), elastic for a foam if both failed
(:func:`_foam_tangent`).
"""

from __future__ import annotations

from .common import _inner
from .elastic import _elastic_update
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


@_inner
def _foam_tangent(d_out, ip, nupd, s_upd, ok_upd, ms, qs, cel, measure, rot, cr, c_eig, h):
    """Write the tangent of foam point ``ip`` from the stresses of its ``nupd`` updates.

    A column whose two perturbed updates both failed is elastic (no plastic state).

    Args:
        d_out: (n, 36) tangent (Mandel, row-major).
        ip: Point index.
        nupd: Number of updates (1 or 13; 1 writes nothing).
        s_upd: (>= nupd, 6) stress of each update (elastic columns are written here).
        ok_upd: (>= nupd,) success of each update.
        ms: (>= nupd, 3, 3) diagonalised C of each update.
        qs: (>= nupd, 3, 3) eigenvectors of C of each update.
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        rot: (6, 6) scratch.
        cr: (6, 6) scratch.
        c_eig: (6, 6) scratch.
        h: Perturbation size.
    """
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
        _tangent_column(d_out, ip, j, s_upd[0], s_upd[2 * j + 1], s_upd[2 * j + 2], okp, okm, h)
