"""Quadrature-point kernels (numba) for the Lagrangian generalised-strain materials.

Conventions:
    * Symmetric tensors are Mandel 6-vectors ``[11, 22, 33, sqrt2*23, sqrt2*13, sqrt2*12]``,
      so that double contractions are plain dot products and fourth-order tensors are
      6x6 matrices.
    * Kinematics: the right Cauchy-Green tensor ``C = F^T F`` with eigenvalues ``c_a``
      and eigenvectors ``N_a``. The Lagrangian strain of the Seth-Hill family is
      ``E = sum_a f(c_a) N_a (x) N_a`` with ``f(c) = ln(c)/2`` (Hencky, measure 0) or
      ``f(c) = sqrt(c) - 1`` (Biot, measure 1), or Biot for ``c >= 1`` and Hencky
      below (measure 2, continuously differentiable at ``c = 1``).
    * Stress ``T`` is work-conjugate to ``E``; the second Piola-Kirchhoff stress is
      ``S = 2 T : dE/dC``; in the eigenbasis of ``C``, ``S_ab = 2 theta_ab T_ab`` with
      ``theta_ab`` the divided difference of ``f`` (Daleckii-Krein).
    * Plasticity is additive in ``E`` (``E = Ee + Ep``); the yield function is written
      in the rotated Cauchy stress ``U S U / J``, which in the eigenbasis of ``C`` is
      ``sigma_ab = kappa_ab T_ab`` with ``kappa_ab = 2 lambda_a lambda_b theta_ab / J``.

The tangent ``D = dS/dE_GL`` is computed by central perturbation of the whole
stress update (Miehe 1996, CMAME 134), which gives the algorithmic (consistent)
tangent up to an O(h^2) truncation error (about 1e-10 relative; larger only where
+/-h straddles the yield surface).

Performance (the tangent takes 13 stress updates per point):
    * Results are bit-for-bit those of the plain formulation: every floating-point
      value that reaches an output is computed by the same operations in the same
      order. This matters because the difference quotient divides round-off in
      ``S`` by ``h``, and the stopping test of the return mapping turns any
      round-off change into another last iterate: a reordered sum alone moves ``D``
      by about 1e-9.
    * Nothing is allocated per point: a kernel call allocates its scratch arrays
      once, and 6-vectors travel as tuples.
    * The inner functions are compiled without the numba runtime (``_inner``), so
      the arrays they pass around are not reference-counted.
    * The 13 eigen-decompositions of a point run as one batch: the Jacobi angles
      of all matrices (divisions and square roots) are computed before the
      rotations, so their latencies overlap.
    * The geometric bracketing of the return mapping only needs the sign of the
      yield value at most of its trial points; a rigorous lower bound proves it
      positive where it is far from zero, which skips the linear solve there
      (:func:`.foam_bound._phi_surely_positive`).

Modules:
    * :mod:`.common`: the ``_inner`` compilation switch and the status codes.
    * :mod:`.mandel`: 6-vector algebra and Mandel rotations.
    * :mod:`.linalg`: the batched 3x3 eigensolver and the 6x6 linear solve.
    * :mod:`.strain`: Seth-Hill strain measures and the eigenframe kinematics.
    * :mod:`.curve`: the hardening curve (Hermite table) and its slope bound.
    * :mod:`.foam_bound`: the lower bound that skips solves in the bracketing.
    * :mod:`.foam`: yield function, return mapping and the foam stress update.
    * :mod:`.elastic`: the elastic stress update.
    * :mod:`.tangent`: the perturbed tensors and columns of the difference tangent.
    * :mod:`.drivers`: the point loops (entry points ``elastic_points``,
      ``foam_points``, and ``foam_frozen_points``: the foam elastic about its
      plastic state, no return mapping).

Caching: numba's on-disk cache of a function is invalidated when the file that
defines it changes, not when a function it calls from another module does. The
package therefore caches under one folder per digest of its sources
(:mod:`forming.kernelcache`): an edit anywhere starts a fresh cache.
"""

from __future__ import annotations

from .common import STATUS_INVERTED, STATUS_OK, STATUS_RETURN_MAP
from .curve import hermite_eval
from .drivers import (
    TANGENT_CLOSED,
    TANGENT_DIFFERENCE,
    TANGENT_NONE,
    elastic_points,
    foam_frozen_points,
    foam_points,
)
from .foam import N_PROPS, PROP_ALPHA, PROP_PT, PROP_VISC
from .linalg import eig_sym3
from .mandel import SQRT2, mandel_rotation
from .strain import MEASURE_BIOT, MEASURE_BIOT_HENCKY, MEASURE_HENCKY, strain_f, strain_theta

__all__ = [
    "MEASURE_BIOT",
    "MEASURE_BIOT_HENCKY",
    "MEASURE_HENCKY",
    "N_PROPS",
    "PROP_ALPHA",
    "PROP_PT",
    "PROP_VISC",
    "SQRT2",
    "TANGENT_CLOSED",
    "TANGENT_DIFFERENCE",
    "TANGENT_NONE",
    "STATUS_INVERTED",
    "STATUS_OK",
    "STATUS_RETURN_MAP",
    "eig_sym3",
    "elastic_points",
    "foam_frozen_points",
    "foam_points",
    "hermite_eval",
    "mandel_rotation",
    "strain_f",
    "strain_theta",
]
