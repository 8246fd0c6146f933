"""A fabric skin as a one-element-thick hyperelastic solid layer.

The strain energy of :class:`~forming.materials.fabric.NonCrimpFabric` is integrated with
two rules (docs/theory.md, "Fabric skins"):

* fibre tension and compression at one point per cell (the centroid). A one-element-thick
  layer then has no fibre contribution to its bending stiffness (a bent layer has zero
  membrane strain at mid-thickness), and fibres at +/-45 deg to the element edges do not
  lock: a fully integrated Q1 hexahedron would impose the two inextensibility constraints
  at each of its 8 points.
* picture-frame shear and the soft matrix with the full 2 x 2 x 2 rule. They resist the
  hourglass modes that the one-point fibre rule leaves, and their bending stiffness is
  that of a soft layer: a few N mm, like a dry fabric's.

Residual and Jacobian are the first and second variations of the energy (UFL); there is
no history, so nothing is evaluated at quadrature points outside the forms.
"""

from __future__ import annotations

import basix
import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.bodies.base import BodyBase
from forming.domain import BodyDomain
from forming.materials.fabric import NonCrimpFabric
from forming.scene import Body, Scene

FIBRE_DEGREE = 1  # one Gauss point per hexahedron
FULL_DEGREE = 2  # 2 x 2 x 2 Gauss points


class FabricBody(BodyBase):
    """A deformable fabric layer: displacement, energy forms and shear-angle output.

    Hyperelastic: no history and nothing evaluated outside the forms, so the body keeps
    the do-nothing material update of :class:`~forming.bodies.base.BodyBase`.

    Args:
        spec: The scene's body; its material is a :class:`NonCrimpFabric`.
        scene: The scene.
        domain: Where the body lives (its mesh and measures).
    """

    def __init__(self, spec: Body, scene: Scene, domain: BodyDomain):
        super().__init__(spec, domain)
        msh = self.mesh
        self.material: NonCrimpFabric = spec.material
        self.quadrature_degree = FULL_DEGREE
        self.n_points = len(self.cells) * 8
        # The fibre integral gets its own subdomain id, hence its own kernel: FFCx 0.11
        # mixes up shared subexpressions when one cell kernel holds integrals of
        # different degrees (the shear term came out wrong by 1e-6 relative at a perturbed
        # state, and the Jacobian lost consistency: tests/test_fabric_cases.py).
        self.dx, self.dx_fibre = domain.dx(FULL_DEGREE, FIBRE_DEGREE)
        self.own_dx = domain.own_dx(FULL_DEGREE)
        F = self.deformation_gradient()
        mat = self.material
        self.energy = ((mat.shear_energy(F) + mat.matrix_energy(F)) * self.dx
                       + mat.fibre_energy(F) * self.dx_fibre)
        # outputs: cell-centre shear angle [deg] and wrinkling indicator
        W = fem.functionspace(msh, ("DG", 0))
        self.shear_angle = fem.Function(W, name="shear_angle_deg")
        self.wrinkling = fem.Function(W, name="wrinkling")
        # the shorter tow's strain: below zero the fibres are compressed in plane
        # (the bundle-wrinkling risk of an NCF)
        self.fibre_strain = fem.Function(W, name="fibre_strain_min")
        dx0 = ufl.Measure("dx", domain=msh, metadata={"quadrature_degree": 0})
        self._wrinkle_forms = (fem.form(self.wrinkling * dx0),
                               fem.form(fem.Constant(msh, 1.0) * dx0))
        gamma = mat.shear_angle(F)
        pts = W.element.interpolation_points
        self._gamma_expr = compat.expression(gamma * 180.0 / np.pi, pts)
        self._wrinkle_expr = compat.expression(mat.wrinkling_indicator(gamma), pts)
        # det F where the matrix energy takes its logarithm: the full rule's points
        full, _weights = basix.make_quadrature(msh.basix_cell(), FULL_DEGREE)
        self._detF_expr = compat.expression(ufl.det(F), full)
        lam1, lam2 = mat.fibre_stretches(F)
        self._fibre_expr = compat.expression(ufl.min_value(lam1, lam2) - 1.0, pts)

    def residual(self, v) -> ufl.Form:
        """Internal virtual work: the first variation of the strain energy."""
        return ufl.derivative(self.energy, self.u, v)

    def jacobian(self, du, v) -> ufl.Form:
        """Second variation of the strain energy."""
        return ufl.derivative(self.residual(v), self.u, du)

    def stability_jacobian(self, du, v) -> ufl.Form:
        """The Jacobian with taut fibres: an upper bound of the stiffness of any state.

        The explicit time step must hold once the fibres come out of their toe (1000 times
        stiffer than at rest with the shipped fabric); with the Jacobian at rest a bias
        extension went unstable in its first output interval.
        """
        F = self.deformation_gradient()
        mat = self.material
        energy = ((mat.shear_energy(F) + mat.matrix_energy(F)) * self.dx
                  + mat.taut_fibre_energy(F) * self.dx_fibre)
        return ufl.derivative(ufl.derivative(energy, self.u, v), self.u, du)

    def viscous_residual(self, v: fem.Function, beta: fem.Constant, w) -> ufl.Form:
        """Stiffness-proportional damping of the fibres, tested with ``w`` (explicit runs).

        Per family a viscous stress ``beta E_t(lam) d(lam)/dt`` along the fibre, at the
        fibre point, with ``E_t`` the fibre's tangent modulus: every mode of the fibres is
        damped at ``beta omega / 2`` of critical, the highest (the fibres' ringing) most.

        Args:
            v: The nodal velocities (a function of the displacement space).
            beta: The damping time [s].
            w: Test function.
        """
        F = self.deformation_gradient()
        form = 0
        for a0 in self.material.fibre_directions:
            a = ufl.as_vector(a0)
            f = F * a
            lam = ufl.sqrt(ufl.dot(f, f))
            rate = ufl.dot(f, ufl.grad(v) * a) / lam
            virtual = ufl.dot(f, ufl.grad(w) * a) / lam
            form = form + (beta * self.material.fibre_tangent_modulus(lam) * rate
                           * virtual * self.dx_fibre)
        return form

    def contact_stiffness(self) -> float:
        """Through-thickness modulus of the layer [MPa] (sets default contact penalties)."""
        m = self.material
        return m.bulk_modulus + 4.0 * m.shear_modulus / 3.0 + m.transverse_shear_modulus

    # -- outputs -------------------------------------------------------------------------
    def update_output(self) -> None:
        """Evaluate the shear angle, wrinkling indicator and fibre strain at the centres."""
        self.shear_angle.interpolate(self._gamma_expr)
        self.wrinkling.interpolate(self._wrinkle_expr)
        self.fibre_strain.interpolate(self._fibre_expr)

    def output_fields(self) -> dict[str, list[fem.Function]]:
        """ParaView fields besides the displacement: file stem -> functions."""
        return {"shear_angle": [self.shear_angle, self.wrinkling, self.fibre_strain]}

    def cell_fields(self) -> dict[str, np.ndarray]:
        """The owned cells' shear angles [deg] at the current state."""
        self.update_output()
        dofs = self.shear_angle.function_space.dofmap.list[self.cells[: self.n_local_cells], 0]
        return {"shear_angle_deg": self.shear_angle.x.array[dofs].copy()}

    def min_det_F(self) -> float:
        """Smallest Jacobian determinant at the full rule's points, over all ranks.

        The matrix energy takes ``ln det F`` there: an iterate that inverts a point of a
        thin skin (one element through its thickness) makes the residual NaN.
        """
        values = self._detF_expr.eval(self.mesh, self.cells[: self.n_local_cells])
        local = float(values.min()) if values.size else np.inf
        return self.mesh.comm.allreduce(local, op=MPI.MIN)

    def wrinkle_area_fraction(self) -> float:
        """Fraction of the layer's reference area beyond a wrinkling angle (call update first).

        Cell-centre indicator, weighted by the reference cell volume (a one-element-thick
        layer: proportional to area).
        """
        num, den = (self.mesh.comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                    for f in self._wrinkle_forms)
        return num / den

    def shear_range_deg(self) -> tuple[float, float]:
        """(min, max) cell-centre shear angle [deg] over all ranks (call update first)."""
        g = self.shear_angle.x.array[: self.n_local_cells]
        lo = self.mesh.comm.allreduce(float(g.min(initial=np.inf)), op=MPI.MIN)
        hi = self.mesh.comm.allreduce(float(g.max(initial=-np.inf)), op=MPI.MAX)
        return lo, hi
