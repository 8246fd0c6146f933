"""Viscous stabilisation of quasi-static implicit runs through local instabilities.

A wall that buckles, or a fold that snaps through, has no static path for Newton to
follow: a load step fails however small it is. As Abaqus/Standard's automatic
stabilisation (``*STATIC, STABILIZE``), a volume-proportional viscous force is added to
every stabilised body,

    r_v = (c / dt) * integral (u - u_n) . v dx,

with ``u_n`` the converged displacement of the last step and ``dt`` the step in the load
parameter. The coefficient ``c`` is set once, after the first step (which runs
without it), so that a step like it would dissipate ``fraction`` of its strain energy:
``c = fraction * W_1 * dt_1 / integral |u_1 - u_0|^2 dx``. Where the body moves
smoothly the force is small; where part of it jumps, the force damps the jump.

The dissipated energy is summed step by step and written to the history
(``stabilisation_energy_Nmm``, next to the bodies' internal work
``internal_work_Nmm``); a run whose dissipated energy is not small against its internal
work says so in its warnings.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, la  # noqa: I001

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.parallel import assemble_scalar
from forming.scene import Stabilisation

WARN_RATIO = 0.05
"""Dissipated over internal work above which a run is warned about."""


class ViscousStabilisation:
    """The viscous force of :class:`~forming.scene.Stabilisation` on a model's bodies.

    Args:
        spec: The scene's stabilisation.
        bodies: The stabilised bodies, by name.
        mesh: The scene mesh (the solve forms' domain).
        entity_maps: The model's maps from the scene mesh to the bodies' submeshes.
    """

    def __init__(self, spec: Stabilisation, bodies: dict, mesh, entity_maps=None):
        self.spec = spec
        self.bodies = bodies
        self.c = 0.0
        self.c_over_dt = fem.Constant(mesh, 0.0)
        self._comm = mesh.comm
        self.u_n = {n: b.u.copy() for n, b in bodies.items()}
        # one form per body: the bodies' measures carry their own subdomain data
        self._du2 = [fem.form(ufl.inner(b.u - self.u_n[n], b.u - self.u_n[n]) * b.dx,
                              entity_maps=entity_maps) for n, b in bodies.items()]
        self._force = {n: fem.form(b.residual(ufl.TestFunction(b.V)), entity_maps=entity_maps,
                                   jit_options=compat.SOLVE_JIT_OPTIONS)
                       for n, b in bodies.items()}
        self._f_n = {n: np.zeros(b.u.x.array.size) for n, b in bodies.items()}
        self.energy = 0.0  # dissipated [N mm]
        self.internal_work = 0.0  # internal work of the stabilised bodies [N mm]
        self._dt = 0.0
        self._warnings: list[str] = []

    def residuals(self, tests: dict) -> dict[str, ufl.Form]:
        """The viscous force's virtual work on each stabilised body."""
        return {n: self.c_over_dt * ufl.inner(b.u - self.u_n[n], tests[n]) * b.dx
                for n, b in self.bodies.items()}

    def set_load(self, dt: float) -> None:
        """The step in the load parameter that the next solve covers."""
        self._dt = dt
        self.c_over_dt.value = self.c / dt if dt > 0 else 0.0

    def commit(self) -> None:
        """Book the step's dissipation and internal work; calibrate ``c`` after the first.

        The internal work of the step is the trapezoidal rule on the internal nodal
        forces, 1/2 (f(u_n) + f(u)) . (u - u_n), prescribed nodes included (there it is
        the work of the fixtures); exact for a linear first step.
        """
        du2 = sum(assemble_scalar(f) for f in self._du2)
        step_work = 0.0
        for n, b in self.bodies.items():
            b.update_material(want_tangent=False)
            f = fem.assemble_vector(self._force[n])
            f.scatter_reverse(la.InsertMode.add)
            owned = b.V.dofmap.index_map.size_local * 3
            du = (b.u.x.array - self.u_n[n].x.array)[:owned]
            step_work += 0.5 * float(np.dot(self._f_n[n][:owned] + f.array[:owned], du))
            self._f_n[n][:] = f.array
            self.u_n[n].x.array[:] = b.u.x.array
        step_work = self._comm.allreduce(step_work)
        self.internal_work += step_work
        self.energy += float(self.c_over_dt.value) * du2
        if self.c == 0.0 and du2 > 0.0 and self._dt > 0.0:
            self.c = self.spec.fraction * abs(step_work) * self._dt / du2
        ratio = self.energy / self.internal_work if self.internal_work > 0 else 0.0
        if ratio > WARN_RATIO and not self._warnings:
            self._warnings.append(
                f"viscous stabilisation dissipated {100 * ratio:.1f}% of the internal work "
                f"(above {100 * WARN_RATIO:g}%): the result depends on the damping; lower "
                "stabilisation.fraction or refine the load steps")

    def snapshot(self) -> tuple:
        """Coefficient, energies and last internal forces.

        The reference state of the viscous force is the bodies' displacement.
        """
        return (np.array([self.c, self.energy, self.internal_work]),
                [f.copy() for f in self._f_n.values()])

    def snapshot_layout(self) -> tuple:
        """The snapshot's structure: the forces live where the displacements do."""
        return (None, [b.domain.layout(b.V) for b in self.bodies.values()])

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot (call after the bodies are restored)."""
        self.c, self.energy, self.internal_work = (float(v) for v in snap[0])
        for (n, b), f in zip(self.bodies.items(), snap[1], strict=True):
            self._f_n[n][:] = f
            self.u_n[n].x.array[:] = b.u.x.array

    def history_columns(self) -> dict[str, float]:
        """The dissipated energy and the internal work so far."""
        return {"stabilisation_energy_Nmm": self.energy, "internal_work_Nmm": self.internal_work}

    def warnings(self) -> list[str]:
        """A warning when the damping did more than a small share of the work."""
        return list(self._warnings)
