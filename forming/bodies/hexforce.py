"""Internal forces of a solid of hexahedra for the explicit solver.

The explicit solver needs the internal force vector once per time increment and no
tangent. :class:`HexInternalForce` computes it without forms: the compiled element
loops of :mod:`.hexkernels` around the material's point kernel (the same stress update
as the implicit solver's, :func:`~forming.materials.solids.point_stress`), on the
rank's owned cells, into a preallocated vector.

Three integrations:

- ``full``: the body's own quadrature points (2 x 2 x 2 Gauss on trilinear hexahedra,
  3 x 3 x 3 on triquadratic ones), the same stress at the same points as the forms of
  the implicit solver; the only one for triquadratic hexahedra (the meso-scale cell
  walls, whose fracturing material's history is the body's own arrays);
- ``reduced``: one point per element with the mean shape-function gradients of
  Flanagan and Belytschko (``b = (1/V) int grad N dV``, exact volume), as Abaqus'
  C3D8R, stabilised against its hourglass modes by the stiffness form of Flanagan and
  Belytschko, measured in the element's rotated frame (corotational, :mod:`.hexkernels`).
  The stiffness of each mode and displacement component is ``kappa``
  times what the fully integrated elastic element puts against that mode
  (:func:`mode_stiffness`): anisotropy and element shape are accounted for, and
  ``kappa = 1`` restores the full element's resistance to pure hourglass modes. The
  forces follow the modes in rate form, scaled by the element's tangent ratio (1 while
  elastic, the hardening's series stiffness while it crushes, at least
  ``plastic_floor``): an elastic hourglass spring would carry load a crushed element no
  longer carries. The plastic history is then one value per element, copied
  to the body's points when it is synchronised;
- ``thickness``: one point in plane and two through the thickness (the Gauss points of
  the element's axis nearest the global z, the core's thickness at the start), as the
  in-plane reduced solid-shells integrate: the two points see the element's bending
  and the gradient of its crushing through the thickness, which the one point cannot.
  The hourglass stiffness of each mode and component is ``kappa`` times what full
  integration puts against it beyond what the two points already do: all of it for
  the in-plane bilinear and the trilinear modes, which the points do not see, the
  in-plane gradients alone (of the crushing, of the membrane strains) for the two
  bending modes. Each body point takes the history of the point on its side of the
  element's mid-plane.

See docs/theory.md, section 12.
"""

from __future__ import annotations

import time

import basix
import numpy as np
from dolfinx import la  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401
from forming.bodies.corners import DistortionControl
from forming.bodies.hexgeometry import (
    mode_stiffness,
    point_geometry,
    thickness_axes,
    thickness_points,
)
from forming.bodies.hexkernels import nodal_forces, right_cauchy_green, tangent_ratio
from forming.errors import InputError, KernelFailure
from forming.materials.solids import point_stress

# Reference coordinates (-1 or +1) of the P1 hexahedron's nodes, basix order.
_XI = 2.0 * basix.create_element(basix.ElementFamily.P, basix.CellType.hexahedron, 1,
                                 ).points - 1.0
# Hourglass base vectors xi eta, eta zeta, zeta xi, xi eta zeta at the nodes (4, 8).
_H = np.array([_XI[:, 0] * _XI[:, 1], _XI[:, 1] * _XI[:, 2], _XI[:, 2] * _XI[:, 0],
               _XI[:, 0] * _XI[:, 1] * _XI[:, 2]])

def loop_timing(loops: list[HexInternalForce], comm) -> dict[str, float]:
    """The element loops' wall time on the busiest rank, and that over the ranks' mean.

    The second is the load imbalance: an element that crushes or deforms much costs
    more in the point kernel than one at rest, and the rank that holds more of them
    sets the pace of every increment. Collective; empty without loops.
    """
    if not loops:
        return {}
    local = sum(loop.seconds for loop in loops)
    most = comm.allreduce(local, op=MPI.MAX)
    mean = comm.allreduce(local, op=MPI.SUM) / comm.size
    return {"element_loops_s": most, "element_loops_imbalance": most / mean if mean else 1.0}


def distortion_energy(loops: list[HexInternalForce], comm) -> float:
    """The distortion control's energy of the loops' elements over all ranks [N mm].

    Collective.
    """
    return comm.allreduce(sum(loop.distortion_energy for loop in loops), op=MPI.SUM)


def loop_metrics(loops: list, comm) -> dict[str, float]:
    """Figures of the element loops for ``summary.json`` metrics; collective.

    ``distortion_energy_Nmm``: the distortion control's energy over all ranks;
    ``full_integration_fraction`` (adaptive integration only): the share of its
    elements fully integrated at the end.
    """
    out = {"distortion_energy_Nmm": distortion_energy(loops, comm)}
    adaptive = [loop for loop in loops if hasattr(loop, "full_fraction")]
    if comm.allreduce(len(adaptive), op=MPI.SUM):
        full = comm.allreduce(sum(int(loop.full.sum()) for loop in adaptive), op=MPI.SUM)
        count = comm.allreduce(sum(loop.n_cells for loop in adaptive), op=MPI.SUM)
        out["full_integration_fraction"] = full / count if count else 0.0
    return out


def smallest_corner_det(loops: list[HexInternalForce]) -> float:
    """Smallest corner determinant ratio of the hourglass-controlled loops' bodies so far.

    Over the accepted states (the history's ``min_corner_det``), the same on every rank;
    1 without such loops.
    """
    return min((loop.body.folded for loop in loops if loop.reduced), default=1.0)


class HexInternalForce:
    """Internal forces of one solid body on hexahedra, element by element.

    Args:
        body: The solid (:class:`~forming.bodies.solid.SolidBody`) on P1 or P2
            hexahedra.
        integration: ``"full"``, ``"reduced"`` (one point, hourglass control) or
            ``"thickness"`` (two points through the thickness, hourglass control of the
            two modes they miss); the last two for P1 only.
        hourglass: Hourglass coefficient ``kappa`` of the reduced elements (>= 0).
        density: Mass density [t/mm^3] (the element frequency bound).
        plastic_floor: Smallest tangent ratio of a plastically flowing element.
        distortion: Corner determinant ratio below which a reduced or thickness element
            is held from folding by the distortion control
            (:class:`~forming.bodies.corners.DistortionControl`); 0: none.
        cells: Positions in the body's :attr:`point_cells` of the elements this loop
            takes (the adaptive integration's two loops); None: all owned cells.

    Raises:
        InputError: Not a hexahedral body of degree 1 or 2, reduced integration of a
            degree-2 or a fracturing body, a negative coefficient, or no density.
    """

    def __init__(self, body, integration: str, hourglass: float, density: float,
                 plastic_floor: float = 0.3, distortion: float = 0.0,
                 cells: np.ndarray | None = None):
        degree = body.spec.degree
        if body.mesh.topology.cell_name() != "hexahedron" or degree not in (1, 2):
            raise InputError(f"body.{body.name}",
                             "the element loops need P1 or P2 hexahedra")
        if integration not in ("full", "reduced", "thickness"):
            raise InputError("explicit.integration", "must be 'full', 'reduced' or "
                             f"'thickness', got {integration!r}")
        if integration != "full" and degree != 1:
            raise InputError("explicit.integration",
                             f"{integration} integration is for P1 hexahedra; body "
                             f"{body.name!r} has degree {degree}")
        if integration == "thickness" and body.damaging:
            raise InputError("explicit.integration", "thickness integration does not take "
                             f"a fracturing body ({body.name!r}): use 'full'")
        if not hourglass >= 0.0:
            raise InputError("explicit.hourglass", f"must be >= 0, got {hourglass!r}")
        if not 0.0 <= distortion < 1.0:
            raise InputError("explicit.distortion_control",
                             f"must lie in [0, 1), got {distortion!r}")
        self.body = body
        self.integration = integration
        self.reduced = integration != "full"  # hourglass-controlled
        element = basix.create_element(basix.ElementFamily.P, basix.CellType.hexahedron,
                                       degree, basix.LagrangeVariant.gll_warped)
        if cells is not None and body.damaging:
            raise InputError("explicit.integration", "a fracturing body's elements are "
                             f"integrated in one loop ({body.name!r})")
        self.nodes, grads, weights, x = point_geometry(body, element, cells)
        self.reference_nodes = x  # (n_cells, n_nodes, 3)
        # each element's position in the body's point_cells
        self.cell_positions = (np.arange(len(self.nodes)) if cells is None
                               else np.asarray(cells, dtype=np.int64))
        # the body's points of this loop's cells, in order (None: all of them)
        self._body_points = None if cells is None else (
            np.asarray(cells, dtype=np.int64)[:, None] * weights.shape[1]
            + np.arange(weights.shape[1])).ravel()
        modulus = float(np.max(np.diag(body.material.kernel_data().cel)))
        # the Flanagan-Belytschko bound is a trilinear element's: a P2 body's step comes
        # from the Gershgorin bound alone, as through its forms
        self.wave2 = modulus / density if degree == 1 else 0.0
        nc = self.nodes.shape[0]
        self.per_cell = {"full": weights.shape[1], "reduced": 1, "thickness": 2}[integration]
        # the loop's point of each body point (n_cells, n_q); None: the body's own points
        self.point_map = None
        if self.reduced:
            volume = weights.sum(axis=1)
            mean = np.einsum("cq,cqaj->caj", weights, grads) / volume[:, None, None]
            # gamma = h - (h . X) b: orthogonal to every linear field
            hx = np.einsum("ma,cai->cmi", _H, x)
            self.gamma = np.ascontiguousarray(_H[None] - np.einsum("cmi,cai->cma", hx, mean))
            cel = body.material.kernel_data().cel
            self.k_hg = hourglass * mode_stiffness(self.gamma, grads, weights, cel)
            if integration == "reduced":
                self.grads = np.ascontiguousarray(mean[:, None])
                self.weights = volume[:, None].copy()
                self.point_map = np.repeat(np.arange(nc)[:, None], weights.shape[1], axis=1)
            else:
                axis = thickness_axes(x)
                g2, self.weights, self.point_map = thickness_points(
                    x, axis, body.QS.element.interpolation_points, mean, volume)
                self.grads = np.ascontiguousarray(g2)
                # what the two points already put against each mode and component (the
                # bending through the thickness) is not stabilised again: the hourglass
                # stiffness is kappa times what full integration adds to it (the
                # in-plane gradients: of the crushing, of the membrane strains)
                seen = mode_stiffness(self.gamma, self.grads, self.weights, cel)
                self.k_hg = np.maximum(self.k_hg - hourglass * seen, 0.0)
        else:
            self.grads = np.ascontiguousarray(grads)
            self.weights = weights
            self.gamma = np.zeros((0, 4, 8))
            self.k_hg = np.zeros((nc, 4, 3))
        n = nc * self.per_cell
        self.fm = np.zeros((n, 9))
        self.cm = np.zeros((n, 9))
        self.detf = np.zeros(n)
        self.stress = np.zeros((n, 6))
        ps = body.plastic
        self.damaging = body.damaging
        self._cells = body.band_geometry  # None unless it fractures
        if not self.reduced and cells is not None:  # a subset's points, in its order
            self.point_map = np.arange(n).reshape(nc, self.per_cell)
        if ps is not None and self.point_map is None:  # the body's own points and arrays
            self.ep, self.evp, self.ep_trial, self.evp_trial = (
                ps.ep, ps.evp, ps.ep_trial, ps.evp_trial)
        else:
            self.ep = np.zeros((n if ps is not None else 0, 6))
            self.evp = np.zeros(n if ps is not None else 0)
            self.ep_trial = self.ep.copy()
            self.evp_trial = self.evp.copy()
        # hourglass state per element: q_n, Q_n, trial q, trial Q; energy and new work
        self.hg = np.zeros((4, nc, 4, 3))
        self.hg_energy = np.zeros((2, nc))
        self.phi = np.ones(nc)
        self._phi_points = np.ones(n)  # the tangent ratio of each point
        k = body.material.kernel_data()
        self._curve = (k.xs, k.ys, k.ds) if k.plastic else None
        self.modulus = modulus
        self.plastic_floor = plastic_floor
        self.distortion = (DistortionControl(self.nodes, x, weights.sum(axis=1), modulus,
                                             modulus / density, distortion)
                           if self.reduced and distortion > 0.0 else None)
        self.omega2 = 0.0  # the largest element frequency bound of the rank [1/s^2]
        self.seconds = 0.0  # wall time of the rank's element work (no scatters) [s]
        self._u = body.u.x.array  # a view: the property builds a new one at every call
        self.pull()

    @property
    def n_cells(self) -> int:
        """Owned elements of the rank."""
        return self.nodes.shape[0]

    def forces(self, out: la.Vector) -> None:
        """Internal forces at the body's displacement into ``out``, summed over ranks.

        Args:
            out: A vector of the body's displacement space (owned and ghost entries are
                written).

        Raises:
            KernelFailure: An inverted element or a failed return mapping on this rank,
                raised after the vector's scatters (which every rank takes part in), with
                this rank's forces left at zero.
        """
        t0 = time.perf_counter()
        arr = out.array
        arr[:] = 0.0
        failure = self.add_local_forces(self._u, arr)
        self.seconds += time.perf_counter() - t0
        out.scatter_reverse(la.InsertMode.add)
        out.scatter_forward()
        if failure:
            raise KernelFailure(failure)

    def add_local_forces(self, u: np.ndarray, out: np.ndarray) -> str:
        """Add this rank's element forces to ``out`` (no scatter); what failed ("": nothing).

        Args:
            u: The body's displacement array (owned and ghost entries).
            out: The array to add the forces to.
        """
        body = self.body
        right_cauchy_green(u, self.nodes, self.grads, self.fm, self.cm, self.detf)
        inverted = self.detf <= 0.0
        if self.damaging:  # an eroded point's shape is no longer checked
            inverted &= body.active_points()
        if inverted.any():
            first = np.zeros(body.n_points, dtype=bool)  # its first point, as the body's
            cell = self.cell_positions[int(np.argmax(inverted)) // self.per_cell]
            first[cell * (body.n_points // len(body.point_cells))] = True
            return (f"{int(np.count_nonzero(inverted))} integration points: inverted "
                    f"elements (det F <= 0) in body {body.name!r}{body.locate(first)}")
        nbad, worst = point_stress(body.material, self.cm, self.ep, self.evp, self.stress,
                                   self.ep_trial, self.evp_trial, body.load_increment,
                                   body.travel, self._cells)
        if nbad:
            what = "inverted elements" if worst == 1 else "return mapping failed"
            return f"{nbad} integration points: {what} in body {body.name!r}"
        if self.reduced and self._curve is not None:
            tangent_ratio(self.ep, self.evp, self.ep_trial, self.evp_trial, *self._curve,
                          self.modulus, self.plastic_floor, self._phi_points)
            self.phi[:] = (self._phi_points if self.per_cell == 1 else
                           self._phi_points.reshape(-1, self.per_cell).mean(axis=1))
        self.omega2 = nodal_forces(u, self.nodes, self.grads, self.weights, self.fm,
                                   self.stress,
                                   self.gamma, self.k_hg, self.phi, self.hg,
                                   self.hg_energy[1], self.wave2, out)
        if self.distortion is not None:
            self.omega2 = max(self.omega2, self.distortion.add_forces(u, out))
        return ""

    @property
    def crushes_at_one_point(self) -> bool:
        """A material that crushes on one point in plane (reduced or thickness)."""
        return self.reduced and self._curve is not None

    @property
    def hourglass_energy(self) -> float:
        """Hourglass energy of the rank's elements at the last evaluation [N mm].

        With the distortion control, its stored energy too (both artificial strain
        energy, Abaqus' ALLAE).
        """
        return float(self.hg_energy.sum()) + self.distortion_energy

    @property
    def distortion_energy(self) -> float:
        """The distortion control's energy of the rank's elements [N mm] (0 without)."""
        return self.distortion.stored if self.distortion is not None else 0.0

    def commit(self) -> None:
        """Accept the trial plastic and hourglass state."""
        self.ep[:] = self.ep_trial
        self.evp[:] = self.evp_trial
        if self.reduced:
            self.hg[:2] = self.hg[2:]
            self.hg_energy[0] += self.hg_energy[1]
            self.hg_energy[1] = 0.0

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Converged hourglass state per element: (q_n and Q_n as (n, 24), energy (n,))."""
        return (np.ascontiguousarray(self.hg[:2].transpose(1, 0, 2, 3)).reshape(-1, 24),
                self.hg_energy[0].copy())

    def set_state(self, state: tuple[np.ndarray, np.ndarray]) -> None:
        """Return the hourglass state to :meth:`state`'s."""
        self.hg[:2] = state[0].reshape(-1, 2, 4, 3).transpose(1, 0, 2, 3)
        self.hg[2:] = self.hg[:2]
        self.hg_energy[0] = state[1]
        self.hg_energy[1] = 0.0

    def state_layout(self) -> tuple:
        """Where :meth:`state`'s arrays live (one row per owned cell)."""
        dom = self.body.domain
        return (dom.point_layout(1, 24), dom.point_layout(1, None))

    def push(self) -> None:
        """Copy the converged plastic state to the body's points (outputs, snapshots)."""
        ps = self.body.plastic
        if ps is None or ps.ep is self.ep:  # (the body's own arrays: nothing to copy)
            self.body.invalidate()
            return
        where = self.point_map.ravel()
        mine = slice(None) if self._body_points is None else self._body_points
        ps.ep[mine] = self.ep[where]
        ps.evp[mine] = self.evp[where]
        ps.ep_trial[mine] = ps.ep[mine]
        ps.evp_trial[mine] = ps.evp[mine]
        self.body.invalidate()

    def pull(self) -> None:
        """Take the body's converged plastic state (the start, or a restored snapshot).

        Each point of a reduced element takes the mean of the body's points it stands for.
        """
        ps = self.body.plastic
        n = self.ep.shape[0]
        if ps is None or n == 0 or ps.ep is self.ep:  # (a rank may own no cell)
            return
        where = self.point_map.ravel()
        mine = slice(None) if self._body_points is None else self._body_points
        count = np.bincount(where, minlength=n).astype(float)
        self.evp[:] = np.bincount(where, ps.evp[mine], minlength=n) / count
        for i in range(6):
            self.ep[:, i] = np.bincount(where, ps.ep[mine, i], minlength=n) / count
        self.ep_trial[:] = self.ep
        self.evp_trial[:] = self.evp
