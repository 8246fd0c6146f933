"""Adaptive integration of a crushable core: one point where it is elastic, eight where it crushes.

The one-point hexahedron with hourglass control is about five times cheaper per increment
than the fully integrated one, but on the shipped meshes (two to four elements through
the core) it misses the crushing where the core bends within an element: under a
punch's edge, over a die's edge radius. That crushing lies in the hourglass modes, which
resist it elastically (docs/validation.md, "Reduced and thickness integration").
Elsewhere the core stays elastic and the one point is enough.

:class:`AdaptiveHexForce` runs two element loops over complementary sets of a body's
elements: a reduced (or thickness-integrated) one and a fully integrated one. It starts
with every element reduced and moves an element to the full loop, for good, as soon as
it begins to crush unevenly: when the determinant of its map at its corners (the local
volume ratio, which the one point does not see) has fallen below ``1 - strain`` at one
corner and differs by more than ``strain`` between its corners. The
element's plastic history moves with it (its one point's state to its eight points);
its hourglass spring is retired, with the work done on it kept in the hourglass energy.
The check runs every ``check_every`` increments on each rank's own elements, with no
communication.

Why the gradient and not the crushing itself: an element that crushes evenly (under
the middle of a punch) is what the one point represents exactly; the one that crushes
on one side only (under the punch's edge, on the inside of a bend) is what it misses,
and there its corners' volume ratios differ. So an element moves when its most
compressed corner has lost more than ``strain`` of its volume and its corners differ by
more than ``strain``. See docs/theory.md, section 12.
"""

from __future__ import annotations

import time

import numpy as np
from dolfinx import la  # noqa: I001

from forming import compat  # noqa: F401
from forming.bodies.corners import corner_dets
from forming.bodies.hexforce import HexInternalForce
from forming.errors import InputError, KernelFailure


class AdaptiveHexForce:
    """Internal forces of a solid of P1 hexahedra, reduced where elastic, full where crushing.

    The same interface as :class:`~forming.bodies.hexforce.HexInternalForce` towards the
    explicit solver.

    Args:
        body: The solid (P1 hexahedra, a crushable material).
        base: Integration of the elements that do not crush: ``"reduced"`` or
            ``"thickness"``.
        hourglass: Hourglass coefficient of the base elements.
        density: Mass density [t/mm^3].
        plastic_floor: Smallest tangent ratio of a crushing base element.
        distortion: Distortion-control ratio of the base elements (0: none).
        strain: Corner compression ``1 - det A / det A_0``, and spread of it over the
            corners, beyond which an element moves to full integration, in (0, 1).
        check_every: Increments between two checks (>= 1).

    Raises:
        InputError: Not P1, a fracturing body, an unknown base, or a bad ``strain``.
    """

    reduced = True  # hourglass-controlled elements (the folded-corner check applies)

    def __init__(self, body, base: str, hourglass: float, density: float,
                 plastic_floor: float = 0.3, distortion: float = 0.0, strain: float = 0.005,
                 check_every: int = 10):
        if base not in ("reduced", "thickness"):
            raise InputError("explicit.integration", f"adaptive base must be 'reduced' or "
                             f"'thickness', got {base!r}")
        if body.spec.degree != 1 or body.damaging:
            raise InputError("explicit.integration", "adaptive integration is for P1 "
                             f"hexahedra without fracture (body {body.name!r})")
        if not 0.0 < strain < 1.0:
            raise InputError("explicit.adaptive_strain", f"must lie in (0, 1), got {strain!r}")
        self.body = body
        self._args = (hourglass, density, plastic_floor, distortion)
        self.base = base
        self.strain = strain
        self.check_every = max(int(check_every), 1)
        n = len(body.point_cells)
        self.full = np.zeros(n, dtype=bool)  # each owned element: fully integrated?
        self._retired = 0.0  # hourglass work of the elements moved to the full loop [N mm]
        self._since = 0
        self.seconds = 0.0
        self._build()

    # -- the two loops ----------------------------------------------------------------------
    def _build(self) -> None:
        """Both loops from :attr:`full` (each takes the body's plastic state)."""
        hourglass, density, floor, distortion = self._args
        self._cells = (np.flatnonzero(~self.full), np.flatnonzero(self.full))
        self._base = HexInternalForce(self.body, self.base, hourglass, density, floor,
                                      distortion, cells=self._cells[0])
        self._full = HexInternalForce(self.body, "full", hourglass, density, floor,
                                      cells=self._cells[1])
        self._det0 = corner_dets(self._base.reference_nodes)

    def move_to_full(self, cells: np.ndarray) -> None:
        """Integrate the elements ``cells`` (positions in the body's owned cells) fully.

        Their converged plastic state goes to their eight points, the work done on their
        hourglass springs stays in the hourglass energy; call between increments.
        """
        cells = np.asarray(cells, dtype=np.int64)
        moving = np.isin(self._cells[0], cells)
        if not moving.any():
            return
        self.push()
        hg, energy = self._base.state()
        self._retired += float(energy[moving].sum())
        self.full[self._cells[0][moving]] = True
        self._build()
        self._base.set_state((hg[~moving], energy[~moving]))

    def _check(self) -> None:
        """Move the base elements that have begun to crush."""
        base = self._base
        if base.n_cells == 0:
            return
        u = self.body.u.x.array.reshape(-1, 3)
        ratio = corner_dets(base.reference_nodes + u[base.nodes]) / self._det0
        low, high = ratio.min(axis=1), ratio.max(axis=1)
        newly = np.flatnonzero((low < 1.0 - self.strain) & (high - low > self.strain))
        if newly.size:
            self.move_to_full(self._cells[0][newly])

    # -- what the explicit solver calls -----------------------------------------------------
    @property
    def n_cells(self) -> int:
        """Owned elements of the rank."""
        return len(self.full)

    @property
    def omega2(self) -> float:
        """The largest element frequency bound of the rank's elements [1/s^2]."""
        return max(self._base.omega2, self._full.omega2)

    @property
    def full_fraction(self) -> float:
        """Share of the rank's elements fully integrated now."""
        return float(self.full.mean()) if len(self.full) else 0.0

    def forces(self, out: la.Vector) -> None:
        """Internal forces at the body's displacement into ``out``, summed over ranks.

        Raises:
            KernelFailure: As :meth:`HexInternalForce.forces`, after the scatters.
        """
        t0 = time.perf_counter()
        u = self.body.u.x.array
        out.array[:] = 0.0
        failure = (self._base.add_local_forces(u, out.array)
                   or self._full.add_local_forces(u, out.array))
        self.seconds += time.perf_counter() - t0
        out.scatter_reverse(la.InsertMode.add)
        out.scatter_forward()
        if failure:
            raise KernelFailure(failure)

    def commit(self) -> None:
        """Accept the increment; every ``check_every`` increments, move crushing elements."""
        self._base.commit()
        self._full.commit()
        self._since += 1
        if self._since >= self.check_every:
            self._since = 0
            t0 = time.perf_counter()
            self._check()
            self.seconds += time.perf_counter() - t0

    @property
    def crushes_at_one_point(self) -> bool:
        """False: an element that crushes is fully integrated from then on."""
        return False

    @property
    def hourglass_energy(self) -> float:
        """Hourglass and distortion energy of the base elements, and the retired work."""
        return self._base.hourglass_energy + self._retired

    @property
    def distortion_energy(self) -> float:
        """The distortion control's energy of the base elements [N mm]."""
        return self._base.distortion_energy

    def push(self) -> None:
        """Both loops' converged plastic state to the body's points."""
        self._base.push()
        self._full.push()

    def pull(self) -> None:
        """Both loops take the body's converged plastic state."""
        self._base.pull()
        self._full.pull()

    def state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per owned element: hourglass state, energy, fully integrated?, check count.

        The hourglass state has 24 values per element, "fully integrated" is 1 or 0, and
        the increments since the last check are the same in every row. The retired
        hourglass work is spread over the fully integrated elements' energy entries, so
        that the sum survives a restart on another number of ranks; the count keeps the
        checks on the same increments as an uninterrupted run's.
        """
        hg = np.zeros((self.n_cells, 24))
        energy = np.zeros(self.n_cells)
        base_hg, base_energy = self._base.state()
        hg[self._cells[0]], energy[self._cells[0]] = base_hg, base_energy
        if self._cells[1].size:
            energy[self._cells[1]] = self._retired / self._cells[1].size
        return hg, energy, self.full.astype(float), np.full(self.n_cells, float(self._since))

    def set_state(self, state: tuple[np.ndarray, ...]) -> None:
        """Return the loops, their hourglass state and the check count to :meth:`state`'s."""
        hg, energy, full, since = state
        self.full = np.asarray(full) > 0.5
        self._retired = float(energy[self.full].sum())
        # (every row holds the count; a rank may own no element after a repartition)
        self._since = int(round(float(np.max(since)))) if len(since) else 0
        self._build()
        base = self._cells[0]
        self._base.set_state((hg[base], energy[base]))

    def state_layout(self) -> tuple:
        """Where :meth:`state`'s arrays live (one row per owned cell)."""
        dom = self.body.domain
        return (dom.point_layout(1, 24), dom.point_layout(1, None),
                dom.point_layout(1, None), dom.point_layout(1, None))
