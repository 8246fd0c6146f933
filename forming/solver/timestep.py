"""The stable time step of the explicit solver, and mass scaling.

The bound is Gershgorin's on the assembled system: the largest eigenvalue of
``M^-1 K`` is at most ``max_i sum_j |K_ij| / m_i``, with K the stiffest tangent each
body may reach soon (:meth:`stability_jacobian`: elastic unloading of a solid, its
plastic state frozen; a fabric's fibres taut) plus every contact penalty a node may
meet, open or not. It is evaluated at the start and then at the start of an output
interval at most every ``explicit.bound_every`` of the load; between two bounds the
explicit solver shortens the step as the stiffest element stiffens
(:meth:`forming.solver.explicit.ExplicitSolver`).
"""

from __future__ import annotations

import math

import numpy as np
from dolfinx import fem  # noqa: I001
from dolfinx.fem.petsc import assemble_matrix, create_matrix
from mpi4py import MPI

from forming import compat  # noqa: F401
from forming.errors import InputError
from forming.solver.lumped import BodyState
from forming.solver.options import ExplicitOptions
from forming.vectors import assembled


class StableStep:
    """Gershgorin bound of the critical time step of a model's bodies.

    Args:
        model: The model.
        states: The explicit state of every body, in the model's order.
        options: Explicit settings (safety factor, mass-scaling target).
    """

    def __init__(self, model, states: list[BodyState], options: ExplicitOptions,
                 damping_ratio: float = 0.0):
        self.states = states
        self.options = options
        self.damping_ratio = damping_ratio
        self.critical = math.inf  # the last undamped bound 2 / omega_max [s]
        self.comm = model.comm
        tests = model.test_functions()
        jac = model.jacobians(stiffest=True)
        estimates = [c.stiffness_estimate(tests) for c in model.constraints]
        # coupled blocks reach into the other bodies: every body's entity map
        maps = model.entity_maps or None
        self._forms = []
        for i, st in enumerate(states):
            # open contacts included; an interface counts twice (the coupling row)
            terms = [e[st.name] for e in estimates if st.name in e]
            pen = sum(terms[1:], terms[0]) if terms else None
            self._forms.append((fem.form(jac[i][i], entity_maps=maps),
                                None if pen is None else fem.form(pen, entity_maps=maps)))
        # one matrix per body, its sparsity built once and refilled at every bound
        self._mats = [create_matrix(jac_form) for jac_form, _pen in self._forms]
        self._f = [fem.Function(st.body.V) for st in states]

    def row_sums(self) -> list[np.ndarray]:
        """Per body, the absolute row sums of its tangent plus every contact penalty.

        ``2 / sqrt(row_i / m_i)`` bounds the stable time step of node i from below.
        """
        sums = []
        for st, (jac, pen), A, f in zip(self.states, self._forms, self._mats, self._f,
                                        strict=True):
            st.body.invalidate()
            # elastic unloading is the stiffest response: plastic state frozen
            st.body.update_material(want_tangent=True, frozen=True)
            A.zeroEntries()
            assemble_matrix(A, jac)
            A.assemble()
            indptr, _cols, data = A.getValuesCSR()
            rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
            local = np.bincount(rows, weights=np.abs(data), minlength=len(indptr) - 1)
            f.x.array[: st.n_owned] = local  # the ghosts come from the scatter
            f.x.scatter_forward()
            total = f.x.array.copy()
            if pen is not None:
                total += assembled(pen)
            # one value per node: the stiffest of its three components
            sums.append(np.repeat(total.reshape(-1, 3).max(axis=1), 3))
            st.body.invalidate()
        return sums

    def scale_masses(self) -> float:
        """Add mass where the stable time step is below the target; the added fraction."""
        target = self.options.target_time_step
        if target is None:
            return 0.0
        added = total = 0.0
        factor = (target / (2.0 * self.options.safety)) ** 2
        for st, k in zip(self.states, self.row_sums(), strict=True):
            st.m = np.maximum(st.m_phys, k * factor)
            added += float(np.sum(st.m[: st.n_owned] - st.m_phys[: st.n_owned]))
            total += float(np.sum(st.m_phys[: st.n_owned]))
        added, total = (self.comm.allreduce(v, op=MPI.SUM) for v in (added, total))
        return added / total

    def time_step(self) -> float:
        """Safety times the Gershgorin bound of the critical time step [s] (collective).

        With a damping ratio ``z`` at the highest frequency (stiffness-proportional
        damping of velocities half a step old) the bound is ``2 / omega (sqrt(1 + z^2) -
        z)``; :attr:`critical` keeps the undamped ``2 / omega``.

        Raises:
            InputError: The model has no stiffness.
        """
        omega2 = 0.0
        for st, k in zip(self.states, self.row_sums(), strict=True):
            n = st.n_owned
            free = ~st.fixed[:n]
            if np.any(free):
                omega2 = max(omega2, float(np.max(k[:n][free] / st.m[:n][free])))
        omega2 = self.comm.allreduce(omega2, op=MPI.MAX)
        if omega2 <= 0:
            raise InputError("explicit", "the model has no stiffness: no stable time step")
        self.critical = 2.0 / math.sqrt(omega2)
        z = self.damping_ratio
        return self.options.safety * self.critical * (math.sqrt(1.0 + z * z) - z)
