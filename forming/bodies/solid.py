"""A solid body whose stress and tangent come from a quadrature-point kernel.

Stress and tangent live in quadrature Functions that a numba kernel fills before each
residual evaluation; history (plastic strain) lives in plain arrays and is allocated
only for a plastic material. See ``docs/theory.md``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from dolfinx import mesh as dmesh
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.bodies.base import BodyBase
from forming.bodies.corners import CornerWatch
from forming.bodies.hexadaptive import AdaptiveHexForce
from forming.bodies.hexforce import HexInternalForce
from forming.bodies.hextangent import HexTangent
from forming.domain import BodyDomain
from forming.errors import InputError, KernelFailure
from forming.kinematics import mandel_contract, mandel_to_tensor, tensor_to_mandel
from forming.materials.solids import PointMaterial, evaluate
from forming.scene import Body, Scene


@dataclass
class PlasticState:
    """Converged and trial history of a plastic body (arrays over quadrature points)."""

    ep: np.ndarray
    evp: np.ndarray
    ep_trial: np.ndarray
    evp_trial: np.ndarray

    @classmethod
    def zeros(cls, n: int) -> PlasticState:
        """State of an undeformed body with ``n`` points."""
        return cls(np.zeros((n, 6)), np.zeros(n), np.zeros((n, 6)), np.zeros(n))

    def commit(self) -> None:
        """Accept the trial state."""
        self.ep[:] = self.ep_trial
        self.evp[:] = self.evp_trial

    def snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        """Copy of the converged state."""
        return self.ep.copy(), self.evp.copy()

    def restore(self, snap: tuple[np.ndarray, np.ndarray]) -> None:
        """Return to a snapshot."""
        self.ep[:], self.evp[:] = snap
        self.ep_trial[:], self.evp_trial[:] = snap


class SolidBody(BodyBase):
    """A deformable solid: displacement, quadrature material data and its forms.

    Args:
        spec: The scene's body.
        scene: The scene (quadrature degree).
        domain: Where the body lives (its mesh and measures).
    """

    def __init__(self, spec: Body, scene: Scene, domain: BodyDomain):
        super().__init__(spec, domain)
        msh = self.mesh
        self.material: PointMaterial = spec.material
        q = scene.quadrature_degree or (2 if spec.degree == 1 else 4)
        self.quadrature_degree = q
        cell = msh.basix_cell()
        self.QS = fem.functionspace(msh, basix.ufl.quadrature_element(cell, value_shape=(6,),
                                                                      degree=q))
        self.QD = fem.functionspace(msh, basix.ufl.quadrature_element(cell, value_shape=(6, 6),
                                                                      degree=q))
        self.S = fem.Function(self.QS, name="S")
        self.D = fem.Function(self.QD, name="D")
        # the kernel runs on the owned cells only: the forms integrate over them alone,
        # so the quadrature data of ghost cells is never read
        self.point_cells = self.cells[: self.n_local_cells]
        self._qdofs = self.QS.dofmap.list[self.point_cells].ravel()
        self.n_points = self._qdofs.size
        # the last evaluation's stress and tangent at the owned points, in their order
        # (what S and D hold there; the compiled element matrices read them)
        self.point_stress = np.zeros((self.n_points, 6))
        self.point_tangent = np.zeros((self.n_points, 36))
        (self.dx,) = domain.dx(q)  # solve forms: on the scene mesh
        self.own_dx = domain.own_dx(q)  # post-processing: on the body's mesh
        F = self.deformation_gradient()
        C = F.T * F
        self._C_expr = compat.expression(
            ufl.as_vector([C[i, j] for i in range(3) for j in range(3)] + [ufl.det(F)]),
            self.QS.element.interpolation_points,
        )
        self.plastic: PlasticState | None = (
            PlasticState.zeros(self.n_points) if self.material.plastic else None
        )
        self.damaging = self.material.kernel_data().damage
        self._cells = self._band_geometry() if self.damaging else None
        self._evp_cells = None  # cell means of the plastic strain or damage (output)
        if self.plastic is not None:
            self._evp_cells = fem.Function(
                fem.functionspace(msh, ("DG", 0)),
                name="damage" if self.damaging else "volumetric_plastic_strain")
        self._evaluated_at: np.ndarray | None = None
        self._has_tangent = False
        travel = scene.travel_mm()
        self.travel = travel or 1.0  # mm per unit load parameter
        if getattr(self.material, "viscosity", 0.0) > 0 and travel is None:
            raise InputError("material.viscosity", "a viscous regularisation is per mm of "
                             "travel, and nothing in the scene moves: give Scene.travel")
        # the corners of P1 hexahedra, watched at every accepted state (history)
        self._corners = None
        if msh.topology.cell_name() == "hexahedron" and spec.degree == 1:
            nodes = self.V.dofmap.list[self.point_cells].astype(np.int64)
            self._corners = CornerWatch(nodes, self.V.tabulate_dof_coordinates()[nodes])
        self.folded = 1.0  # smallest corner determinant ratio so far
        self._warm_kernel()

    def _band_geometry(self) -> tuple[np.ndarray, int]:
        """Inverse Jacobians at the owned cells' centres and points per cell (crack bands)."""
        centre = np.full((1, 3), 0.5)
        jac = compat.expression(ufl.Jacobian(self.mesh), centre)
        j = jac.eval(self.mesh, self.point_cells).reshape(-1, 3, 3)
        ginv = np.linalg.inv(j).reshape(-1, 9) if j.size else np.zeros((0, 9))
        return np.ascontiguousarray(ginv), self.QS.dofmap.list.shape[1]

    def _warm_kernel(self) -> None:
        """Compile (or load from cache) the numba kernel before timing starts."""
        c = np.eye(3).reshape(1, 9)
        evaluate(self.material, c, want_tangent=True)

    def first_piola(self):
        """UFL first Piola-Kirchhoff stress from the quadrature stress."""
        return self.deformation_gradient() * mandel_to_tensor(self.S)

    def residual(self, v) -> ufl.Form:
        """Internal virtual work."""
        return ufl.inner(self.first_piola(), ufl.grad(v)) * self.dx

    def jacobian(self, du, v) -> ufl.Form:
        """Consistent linearisation of :meth:`residual` using the quadrature tangent."""
        F = self.deformation_gradient()
        dF = ufl.grad(du)
        dE_m = tensor_to_mandel(ufl.sym(F.T * dF))
        dP = dF * mandel_to_tensor(self.S) + F * mandel_to_tensor(mandel_contract(self.D, dE_m))
        return ufl.inner(dP, ufl.grad(v)) * self.dx

    # -- quadrature-point update ---------------------------------------------------------
    def update_material(self, want_tangent: bool = True, frozen: bool = False) -> None:
        """Evaluate stress (and tangent, trial state) at the current displacement.

        ``frozen`` evaluates a plastic material elastically about its committed plastic
        state (the unloading stiffness); call :meth:`invalidate` afterwards.

        Raises:
            KernelFailure: An element is inverted or a return mapping failed.
        """
        key = self.u.x.array
        if (not frozen and self._evaluated_at is not None and want_tangent <= self._has_tangent
                and np.array_equal(self._evaluated_at, key)):
            return
        t0 = time.perf_counter()
        cj = self._C_expr.eval(self.mesh, self.point_cells).reshape(-1, 10)
        inverted = cj[:, 9] <= 0.0
        inverted &= self.active_points()  # an eroded point's shape is no longer checked
        n_inverted = int(np.count_nonzero(inverted))
        if n_inverted:  # C alone cannot tell an inverted element
            self._evaluated_at = None
            raise KernelFailure(f"{n_inverted} quadrature points: inverted elements (det F <= 0)"
                                f" in body {self.name!r}{self.locate(inverted)}")
        cm = cj[:, :9]
        ps = self.plastic
        res = evaluate(
            self.material, cm, None if ps is None else ps.ep, None if ps is None else ps.evp,
            want_tangent=want_tangent, load_increment=self.load_increment, frozen=frozen,
            travel=self.travel, cells=self._cells,
        )
        self.kernel_seconds += time.perf_counter() - t0
        if res.n_failed:
            self._evaluated_at = None
            what = "inverted elements" if res.worst_status == 1 else "return mapping failed"
            raise KernelFailure(f"{res.n_failed} quadrature points: {what} in body "
                                f"{self.name!r}")
        self.S.x.array.reshape(-1, 6)[self._qdofs] = res.S
        self.point_stress = res.S
        if want_tangent:
            self.D.x.array.reshape(-1, 36)[self._qdofs] = res.D
            self.point_tangent = res.D
        if frozen:
            self._evaluated_at = None
            return
        if ps is not None:
            ps.ep_trial[:] = res.ep
            ps.evp_trial[:] = res.evp
        self._evaluated_at = key.copy()
        self._has_tangent = want_tangent

    def invalidate(self) -> None:
        """Forget the cached evaluation (after the state or ``u`` changed outside SNES)."""
        self._evaluated_at = None

    # -- history -------------------------------------------------------------------------
    def commit(self) -> None:
        """Accept the trial plastic state as converged."""
        if self.plastic is not None:
            self.plastic.commit()
        self.invalidate()

    def snapshot(self) -> tuple:
        """Copy of the displacement, the converged plastic state and its stress.

        The stress is kept so that forms evaluated after a restore (reactions, output)
        see the converged state, not the last (failed) iterate.
        """
        return (self.u.x.array.copy(),
                None if self.plastic is None else self.plastic.snapshot(),
                self.S.x.array.copy())

    def restore(self, snap: tuple) -> None:
        """Return to a snapshot."""
        self.u.x.array[:] = snap[0]
        if snap[1] is not None:
            self.plastic.restore(snap[1])
        self.S.x.array[:] = snap[2]
        self.invalidate()

    def snapshot_layout(self) -> tuple:
        """Layouts of the displacement, the plastic state (per point) and the stress."""
        plastic = None
        if self.plastic is not None:
            per_cell = self.QS.dofmap.list.shape[1]  # points per cell
            plastic = (self.domain.point_layout(per_cell, 6),
                       self.domain.point_layout(per_cell, None))
        return (self.domain.layout(self.V), plastic, self.domain.layout(self.QS))

    def explicit_internal_force(self, integration: str, hourglass: float, density: float,
                                plastic_floor: float = 0.3, distortion: float = 0.0,
                                adaptive_strain: float = 0.005
                                ) -> HexInternalForce | AdaptiveHexForce | None:
        """Element loops for the explicit solver on hexahedra; None: use the forms.

        ``integration`` applies to P1 hexahedra; P2 ones (the meso-scale walls) are
        always fully integrated, and so are fracturing ones under ``thickness``.
        """
        if self.mesh.topology.cell_name() != "hexahedron" or self.spec.degree not in (1, 2):
            return None
        if self.spec.degree == 2 or (integration in ("thickness", "adaptive")
                                     and self.damaging):
            integration = "full"
        if integration == "adaptive":
            if not self.material.kernel_data().plastic:  # nothing ever crushes
                return HexInternalForce(self, "thickness", hourglass, density,
                                        plastic_floor, distortion)
            return AdaptiveHexForce(self, "thickness", hourglass, density, plastic_floor,
                                    distortion, adaptive_strain)
        return HexInternalForce(self, integration, hourglass, density, plastic_floor,
                                distortion)

    def compiled_tangent(self) -> HexTangent | None:
        """Compiled element matrices on P1 hexahedra with 8 points; None: the form."""
        if (self.mesh.topology.cell_name() != "hexahedron" or self.spec.degree != 1
                or self.quadrature_degree != 2):
            return None
        return HexTangent(self)

    @property
    def band_geometry(self) -> tuple[np.ndarray, int] | None:
        """A fracturing body's crack-band geometry (None for other materials).

        The owned cells' inverse Jacobians at their centres (cells, 9) and the points per
        cell, as :func:`~forming.materials.solids.evaluate` takes them.
        """
        return self._cells

    def contact_stiffness(self) -> float:
        """Largest diagonal elastic modulus [MPa] (sets default contact penalties)."""
        return float(np.max(np.diag(self.material.kernel_data().cel)))

    # -- outputs -------------------------------------------------------------------------
    def output_fields(self) -> dict[str, list[fem.Function]]:
        """ParaView fields besides the displacement: file stem -> functions."""
        if self._evp_cells is None:
            return {}
        return {"damage" if self.damaging else "plastic_strain": [self._evp_cells]}

    def update_output(self) -> None:
        """Cell means of the converged plastic strain (or damage) into the output fields."""
        if self.plastic is not None:
            f = self._evp_cells
            f.x.array[: self.n_local_cells] = self.cell_average(
                self.plastic.ep[:, 0] if self.damaging else self.plastic.evp)
            f.x.scatter_forward()

    def locate(self, points: np.ndarray) -> str:
        """``, the first in the cell at (x, y, z) mm`` for a mask over the points.

        The points are cell by cell, the same number in each (:attr:`point_cells`).
        """
        per_cell = self.n_points // len(self.point_cells)
        cell = self.point_cells[int(np.argmax(points)) // per_cell]
        mid = dmesh.compute_midpoints(self.mesh, 3, np.array([cell], dtype=np.int32))[0]
        return f", the first in the cell at ({mid[0]:.3g}, {mid[1]:.3g}, {mid[2]:.3g}) mm"

    def min_det_F(self) -> float:
        """Smallest Jacobian determinant over the quadrature points of all ranks.

        Eroded points (a fracturing material's) are left out.
        """
        cj = self._C_expr.eval(self.mesh, self.point_cells).reshape(-1, 10)
        det = cj[:, 9][self.active_points()] if cj.size else cj[:, 9]
        local = float(det.min()) if det.size else np.inf
        return self.mesh.comm.allreduce(local, op=MPI.MIN)

    def track_corners(self) -> float | None:
        """Smallest det of the elements' maps at their corners over the reference, now.

        Collective; None for a body that is not of P1 hexahedra. The smallest over the
        calls (the accepted states: the history's ``min_corner_det``) is :attr:`folded`.
        """
        if self._corners is None:
            return None
        now = self.mesh.comm.allreduce(self._corners.smallest(self.u.x.array), op=MPI.MIN)
        self.folded = min(self.folded, now)
        return now

    def cell_average(self, values: np.ndarray) -> np.ndarray:
        """Average of point values (of :attr:`point_cells`) over each owned cell."""
        if self.n_local_cells == 0:  # a rank may own none of a body's cells
            return np.zeros(0)
        return values.reshape(self.n_local_cells, -1).mean(axis=1)

    def warnings(self) -> list[str]:
        """Folded elements; a crushing strain beyond the material's curve (collective).

        A folded element (:attr:`folded` at or below 0) has turned inside out near a node.
        The hardening law is extrapolated past the curve's last point; a run
        that gets there depends on an extrapolation nobody measured.
        """
        out = [] if self.folded > 0.0 else [
            f"body {self.name}: elements folded at their corners (the det of an element's "
            f"map down to {self.folded:.3g} of its reference value) while their points kept "
            "det F > 0 (as under a punch's corner, docs/validation.md); refine the mesh "
            "there"]
        if self.damaging:
            return out + self._band_warnings()
        table = getattr(self.material, "hardening", None)
        if self.plastic is None or table is None:
            return out
        reached = self.mesh.comm.allreduce(float(self.plastic.evp.max(initial=0.0)), op=MPI.MAX)
        last = float(table.evp[-1])
        if reached <= last * (1 + 1e-9):
            return out
        curve = self.material.curve
        return out + [f"body {self.name}: volumetric plastic strain {reached:.3g} passed the "
                      f"last point of its compression curve ({last:.3g}, nominal strain "
                      f"{curve.strain[-1]:g}, from {curve.source}): the hardening was "
                      "extrapolated"]

    def _band_warnings(self) -> list[str]:
        """Crack bands wider than the material's widest (collective)."""
        widest = self.material.widest_band
        wide = self.mesh.comm.allreduce(int(np.count_nonzero(self.plastic.ep[:, 1] > widest)))
        if not wide:
            return []
        return [f"body {self.name}: {wide} damaged points have crack bands wider than "
                f"{widest:.3g} mm (2 G_f / (sigma_f eps_f)): they soften as steeply as the law "
                "allows and dissipate more than the fracture energy; refine the mesh"]

    def active_points(self) -> np.ndarray:
        """True at the points that still carry stress (all but a fracturing body's eroded)."""
        if not self.damaging:
            return np.ones(self.n_points, dtype=bool)
        return self.plastic.ep[:, 4] == 0.0

    def live_cells(self) -> np.ndarray:
        """True at the cells of :attr:`point_cells` with a point that still carries stress."""
        if not len(self.point_cells):
            return np.zeros(0, dtype=bool)
        return self.active_points().reshape(len(self.point_cells), -1).any(axis=1)

    @property
    def erodes(self) -> bool:
        """True when points can erode: a tool's contact then follows what erosion uncovers."""
        return bool(self.damaging and self.material.erodes)

    def damage(self) -> np.ndarray | None:
        """Converged damage per quadrature point (None unless the material fractures)."""
        return self.plastic.ep[:, 0] if self.damaging else None

    def dissipated_density(self) -> np.ndarray | None:
        """Energy fracture dissipated per unit reference volume at each point [MPa]."""
        return self.plastic.ep[:, 2] if self.damaging else None

    def volumetric_plastic_strain(self) -> np.ndarray | None:
        """Converged volumetric plastic strain per quadrature point (None if elastic)."""
        return None if self.plastic is None or self.damaging else self.plastic.evp
