"""Elastic stress update at one point (no plastic state).

Used by the elastic solid, and by the foam for a tangent column whose two perturbed
updates both failed. The eigenframe strain has no shear part, so only three columns
of the rotated stiffness are formed.
"""

from __future__ import annotations

from .common import STATUS_INVERTED, STATUS_OK, _inner
from .mandel import _ZERO6, _mandel_rotation_into, _mul6, _mv6, _stiffness_in_frame
from .strain import _kinematics


@_inner
def _elastic_state(c, q, cel, measure, rot, cr, c_eig, ncol):
    """Elastic stress T at one point, in the eigenframe of C.

    Args:
        c: Eigenvalues of C (3-tuple).
        q: (3, 3) eigenvectors of C (columns).
        cel: (6, 6) Mandel elastic stiffness in the material frame.
        measure: Strain measure (0 Hencky, 1 Biot, 2 Biot-Hencky).
        rot: (6, 6) output: Mandel rotation of the eigenframe.
        cr: (6, 6) scratch.
        c_eig: (6, 6) output: stiffness in the eigenframe, its first ``ncol`` columns
            (3 are enough for T; the tangent needs 6).
        ncol: Columns of ``c_eig`` to form (3 or 6).

    Returns:
        (C positive definite, S-scalings ``2 theta``, T), Mandel 6-tuples in the
        eigenframe (zero if C is not positive definite).
    """
    ok, e_eig, s_fac, _k = _kinematics(c, measure, False)
    if not ok:
        return False, _ZERO6, _ZERO6
    _mandel_rotation_into(q, rot)
    # The eigenframe strain has no shear part: T needs the first 3 columns only (the
    # dropped terms are signed zeros, which leave a sum started at +0.0 unchanged).
    _stiffness_in_frame(rot, cel, cr, c_eig, ncol)
    e0, e1, e2 = e_eig[0], e_eig[1], e_eig[2]
    t0 = 0.0 + c_eig[0, 0] * e0 + c_eig[0, 1] * e1 + c_eig[0, 2] * e2
    t1 = 0.0 + c_eig[1, 0] * e0 + c_eig[1, 1] * e1 + c_eig[1, 2] * e2
    t2 = 0.0 + c_eig[2, 0] * e0 + c_eig[2, 1] * e1 + c_eig[2, 2] * e2
    t3 = 0.0 + c_eig[3, 0] * e0 + c_eig[3, 1] * e1 + c_eig[3, 2] * e2
    t4 = 0.0 + c_eig[4, 0] * e0 + c_eig[4, 1] * e1 + c_eig[4, 2] * e2
    t5 = 0.0 + c_eig[5, 0] * e0 + c_eig[5, 1] * e1 + c_eig[5, 2] * e2
    return True, s_fac, (t0, t1, t2, t3, t4, t5)


@_inner
def _elastic_update(c, q, cel, measure, rot, cr, c_eig):
    """Elastic stress at one point (:func:`_elastic_state`, S global).

    Returns:
        (status, S as a Mandel 6-tuple in the global frame, zero on failure).
    """
    ok, s_fac, t = _elastic_state(c, q, cel, measure, rot, cr, c_eig, 3)
    if not ok:
        return STATUS_INVERTED, _ZERO6
    return STATUS_OK, _mv6(rot, _mul6(s_fac, t))
