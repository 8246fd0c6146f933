"""What every deformable body offers the model and the solvers, and what they share.

A body owns its displacement field, its bulk forms (internal virtual work and its
linearisation), whatever state lives at its quadrature points, and its output fields.
The model adds loads, tool contacts and interfaces on top; the solvers see only the
members of :class:`DeformableBody`.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.domain import BodyDomain
from forming.kinematics import deformation_gradient
from forming.scene import Body


class DeformableBody(Protocol):
    """A deformable body of a model (a solid or a fabric layer).

    Attributes:
        spec: The scene's description of the body (name, material, region).
        domain: Its mesh and measures.
        mesh: Its own mesh (the scene mesh or a cell submesh).
        V: Its displacement space.
        u: Its displacement.
        dx: Cell measure of the solve forms (on the scene mesh).
        own_dx: Cell measure on its own mesh (post-processing).
        quadrature_degree: Quadrature degree of the bulk integrals.
        cells: Owned then ghost cells of its own mesh.
        n_local_cells: Number of owned cells.
        n_points: Quadrature points evaluated by its kernel on this rank.
        plastic: Its plastic history, or None.
        load_increment: Step in the load parameter (viscous regularisation).
        kernel_seconds: Time spent in its quadrature-point kernel.
        erodes: Whether its elements can erode (a tool contact then follows the faces
            that erosion uncovers, :mod:`forming.contact.exposed`).
    """

    spec: Body
    domain: BodyDomain
    V: fem.FunctionSpace
    u: fem.Function
    quadrature_degree: int
    n_local_cells: int
    n_points: int
    load_increment: float
    kernel_seconds: float
    erodes: bool

    def deformation_gradient(self):
        """UFL deformation gradient."""

    def residual(self, v) -> ufl.Form:
        """Internal virtual work tested with ``v``."""

    def jacobian(self, du, v) -> ufl.Form:
        """Linearisation of :meth:`residual` in the direction ``du``."""

    def update_material(self, want_tangent: bool = True, frozen: bool = False) -> None:
        """Evaluate quadrature-point stress (and tangent) at the current displacement."""

    def invalidate(self) -> None:
        """Forget a cached quadrature-point evaluation."""

    def commit(self) -> None:
        """Accept the trial history as converged."""

    def snapshot(self) -> tuple:
        """Copy of the converged state (displacement and history)."""

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""

    def snapshot_layout(self) -> tuple:
        """Where the arrays of :meth:`snapshot` live (:class:`~forming.domain.CellLayout`).

        The same structure as the snapshot, with a layout in place of every array that
        is distributed over the mesh (None elsewhere): a checkpoint on disk stores those
        arrays cell by cell, readable on another number of ranks (:mod:`forming.restart`).
        """

    def contact_stiffness(self) -> float:
        """Modulus [MPa] that sets default contact penalties."""

    def output_fields(self) -> dict[str, list[fem.Function]]:
        """ParaView fields besides the displacement: file stem -> functions."""

    def update_output(self) -> None:
        """Bring the output fields up to the converged state."""

    def cell_fields(self) -> dict[str, np.ndarray]:
        """Cell-wise results kept in ``final_shape.npz`` (name -> owned cells' values)."""

    def min_det_F(self) -> float:
        """Smallest Jacobian determinant over all ranks."""

    def track_corners(self) -> float | None:
        """Smallest corner determinant of its hexahedra now (collective), or None."""

    def warnings(self) -> list[str]:
        """What a user should know about the run's use of this body (collective)."""

    def stability_jacobian(self, du, v) -> ufl.Form:
        """A Jacobian at least as stiff as any the body reaches soon (explicit time step)."""

    def viscous_residual(self, v: fem.Function, beta: fem.Constant, w) -> ufl.Form | None:
        """Stiffness-proportional damping forces at velocities ``v``, or None (explicit runs)."""

    def explicit_internal_force(self, integration: str, hourglass: float, density: float,
                                plastic_floor: float = 0.3, distortion: float = 0.0,
                                adaptive_strain: float = 0.005):
        """Element loops for the explicit solver, or None to use the form.

        The loops are a :class:`~forming.bodies.hexforce.HexInternalForce` or, for
        ``integration="adaptive"``, a :class:`~forming.bodies.hexadaptive.AdaptiveHexForce`.
        """

    def compiled_tangent(self):
        """Compiled element matrices of :meth:`jacobian`, or None to assemble the form.

        The matrices are a :class:`~forming.bodies.hextangent.HexTangent`.
        """


class BodyBase:
    """The members every body shares: spaces, cells, kinematics, displacement state.

    A body without quadrature-point state (a hyperelastic fabric whose energy is a UFL
    form) inherits the do-nothing :meth:`update_material` and :meth:`invalidate`.

    Args:
        spec: The scene's body.
        domain: Where the body lives.
    """

    plastic = None
    load_increment = 0.0
    erodes = False

    def __init__(self, spec: Body, domain: BodyDomain):
        self.spec = spec
        self.domain = domain
        self.mesh = domain.mesh
        self.material = spec.material
        self.V = fem.functionspace(self.mesh, ("Lagrange", spec.degree, (3,)))
        self.u = fem.Function(self.V, name="u")
        self.n_local_cells, self.cells = domain.n_owned_cells, domain.own_cells
        self.kernel_seconds = 0.0

    @property
    def name(self) -> str:
        """The body's name in the scene."""
        return self.spec.name

    def deformation_gradient(self):
        """UFL deformation gradient of the body's displacement."""
        return deformation_gradient(self.u)

    def update_material(self, want_tangent: bool = True, frozen: bool = False) -> None:
        """Nothing to evaluate: the body's stress is a UFL expression of ``u``."""

    def invalidate(self) -> None:
        """Nothing cached."""

    def commit(self) -> None:
        """Accept the trial history (none by default)."""

    def snapshot(self) -> tuple:
        """Copy of the displacement (and history, for a body that has one)."""
        return (self.u.x.array.copy(), None)

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""
        self.u.x.array[:] = snap[0]
        self.invalidate()

    def snapshot_layout(self) -> tuple:
        """The displacement's layout (see :meth:`snapshot`)."""
        return (self.domain.layout(self.V), None)

    def track_corners(self) -> float | None:
        """None by default: no P1 hexahedra to watch."""
        return None

    def warnings(self) -> list[str]:
        """None by default."""
        return []

    def stability_jacobian(self, du, v) -> ufl.Form:
        """The Jacobian that bounds the explicit time step: :meth:`jacobian` by default."""
        return self.jacobian(du, v)

    def viscous_residual(self, v: fem.Function, beta: fem.Constant, w) -> ufl.Form | None:
        """None: the body has no damping of its own (a fabric's fibres have)."""
        del v, beta, w

    def explicit_internal_force(self, integration: str, hourglass: float, density: float,
                                plastic_floor: float = 0.3, distortion: float = 0.0,
                                adaptive_strain: float = 0.005):
        """None: the explicit solver assembles this body's internal forces from its form."""
        del integration, hourglass, density, plastic_floor, distortion, adaptive_strain

    def compiled_tangent(self):
        """None: the implicit solver assembles this body's Jacobian from its form."""

    def cell_fields(self) -> dict[str, np.ndarray]:
        """No cell-wise results in ``final_shape.npz``."""
        return {}

    def nodal_coordinates(self) -> np.ndarray:
        """Reference coordinates of the owned displacement nodes, (n, 3)."""
        return self.V.tabulate_dof_coordinates()[: self.V.dofmap.index_map.size_local]

    def nodal_displacements(self) -> np.ndarray:
        """Displacements of the owned nodes, (n, 3)."""
        n = self.V.dofmap.index_map.size_local
        return self.u.x.array.reshape(-1, 3)[:n]
