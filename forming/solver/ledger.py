"""The energy ledger of an explicit run.

Each rank adds the works of its own nodes at every increment; the sums over ranks are
taken once per output interval (:meth:`EnergyLedger.close_interval`), so an increment
needs no collective call for its bookkeeping. The internal energy includes the
hourglass energy of reduced-integration elements, which is also reported on its own
(Abaqus' ALLAE within ALLIE).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from mpi4py import MPI

_KEYS = ("internal", "external", "friction", "damping")
IE_FLOOR = 0.05  # internal energy, as a share of the run's largest, below which no ratio counts
LOAD_FLOOR = 0.05  # load parameter below which no ratio counts
KE_BLOWUP = 2.0  # kinetic energy over the external work past which a run blew up
KE_FLOOR = 1e-9  # kinetic energy [N mm] below which nothing blew up (a run's start)


@dataclass
class EnergyLedger:
    """Energies [N mm] over all ranks at the last interval's end, and the ratios' rows.

    The kinetic and hourglass energies are compared with the internal energy over "the
    majority of the process" (the Abaqus guideline for quasi-static explicit runs): every
    interval's end from :data:`LOAD_FLOOR` of the load on where the internal energy is at
    least :data:`IE_FLOOR` of the largest the run has reached. Near the start of a load
    the internal energy grows as the square of the load while the tools already move, so
    the ratio there grows without bound however slowly the load goes (under the smooth
    step it falls only as 1/T^2 with the loading time T); a cycle through zero strain,
    as the picture frame's, has no internal energy to compare with either.

    Attributes:
        energy: kinetic, internal, friction, damping, external work and hourglass.
        balance_max: Largest absolute energy balance.
        rows: One row per interval's end: load parameter, kinetic, internal and hourglass
            energy [N mm].
        carried: Largest kinetic and hourglass ratios of a restart's earlier part when
            its checkpoint kept no rows (written before rows were kept).
    """

    energy: dict[str, float] = field(default_factory=lambda: dict.fromkeys(
        ("kinetic", "internal", "friction", "damping", "external", "hourglass"), 0.0))
    balance_max: float = 0.0
    rows: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    carried: tuple[float, float] = (0.0, 0.0)
    _pending: np.ndarray = field(default_factory=lambda: np.zeros(len(_KEYS)))

    def add(self, internal: float, external: float, friction: float, damping: float) -> None:
        """Add one increment's works of this rank's nodes."""
        p = self._pending
        p[0] += internal
        p[1] += external
        p[2] += friction
        p[3] += damping

    def close_interval(self, comm: MPI.Comm, kinetic: float, hourglass: float,
                       load: float) -> str:
        """Sum the interval's works over ranks; record the energies and the row.

        Args:
            comm: The model's communicator.
            kinetic: Kinetic energy now (of this rank's nodes).
            hourglass: Hourglass energy now (of this rank's elements).
            load: Load parameter now.

        Returns:
            "" or, where the integration blew up, why (:meth:`blown_up`); the caller
            then fails the interval, and its restore returns the ledger to the start.
        """
        local = np.concatenate([self._pending, [kinetic, hourglass]])
        total = np.zeros_like(local)
        comm.Allreduce(local, total, op=MPI.SUM)
        self._pending[:] = 0.0
        e = self.energy
        for key, value in zip(_KEYS, total[:4], strict=True):
            e[key] += float(value)
        e["kinetic"], e["hourglass"] = float(total[4]), float(total[5])
        self.rows = np.vstack([self.rows, [load, e["kinetic"], e["internal"], e["hourglass"]]])
        self.balance_max = max(self.balance_max, abs(self.balance()))
        return self.blown_up()

    def blown_up(self) -> str:
        """Why the energies show a blown-up integration ("" where they do not).

        Kinetic + internal + friction + damping energy equals the external work, and
        none of the last three can be negative for the materials and interfaces of a
        scene; so the kinetic energy cannot exceed the external work. Past
        :data:`KE_BLOWUP` times it, energy came from the integration itself (an element
        inverted or eroded under load, a time step above the stable one): the internal
        energy then runs negative as fast as the kinetic one grows, and the balance,
        made of the same forces, still closes.
        """
        e = self.energy
        if e["kinetic"] <= max(KE_BLOWUP * abs(e["external"]), KE_FLOOR):
            return ""
        return (f"unstable: the kinetic energy ({e['kinetic']:.4g} N mm) is more than "
                f"{KE_BLOWUP:g} times the external work ({e['external']:.4g} N mm), with an "
                f"internal energy of {e['internal']:.4g} N mm: the integration blew up")

    def _ratio_max(self, column: int) -> float:
        r = self.rows
        ie = r[:, 2]
        counted = (r[:, 0] >= LOAD_FLOOR) & (ie > 0) & (ie >= IE_FLOOR * ie.max(initial=0.0))
        return float(np.max(r[counted, column] / ie[counted], initial=0.0))

    @property
    def ke_ie_max(self) -> float:
        """Largest kinetic over internal energy over the counted rows (class docstring)."""
        return max(self._ratio_max(1), self.carried[0])

    @property
    def hg_ie_max(self) -> float:
        """Largest hourglass over internal energy over the counted rows."""
        return max(self._ratio_max(3), self.carried[1])

    def balance(self) -> float:
        """Kinetic + internal + friction + damping - external work [N mm]."""
        e = self.energy
        return e["kinetic"] + e["internal"] + e["friction"] + e["damping"] - e["external"]

    def state(self) -> dict:
        """Copy of the ledger (a snapshot)."""
        return {"energy": dict(self.energy), "balance_max": self.balance_max,
                "rows": self.rows.copy(), "carried": list(self.carried)}

    def set_state(self, state: dict | tuple) -> None:
        """Return to a snapshot (or to a checkpoint's tuple written before rows were kept)."""
        if isinstance(state, dict):
            self.energy = dict(state["energy"])
            self.balance_max = float(state["balance_max"])
            self.rows = np.asarray(state["rows"], dtype=float).reshape(-1, 4)
            self.carried = (float(state["carried"][0]), float(state["carried"][1]))
        else:  # (energy, ke_ie_max, hg_ie_max, balance_max[, ie_peak])
            energy, ke, hg, self.balance_max, *_ = state
            self.energy = dict(energy)
            self.rows = np.zeros((0, 4))
            self.carried = (float(ke), float(hg))
        self._pending[:] = 0.0

    def columns(self) -> dict[str, float]:
        """History columns [N mm]."""
        e = self.energy
        return {"energy_kinetic_Nmm": e["kinetic"], "energy_internal_Nmm": e["internal"],
                "energy_hourglass_Nmm": e["hourglass"], "energy_friction_Nmm": e["friction"],
                "energy_damping_Nmm": e["damping"], "work_external_Nmm": e["external"],
                "energy_balance_Nmm": self.balance()}

    def balance_error(self) -> float:
        """Largest energy balance over the external work (0 without external work)."""
        ext = abs(self.energy["external"])
        return self.balance_max / ext if ext > 0 else 0.0


def run_warnings(led: EnergyLedger, opts, mass_added: float, mass_limit: float,
                 one_point_crushing: bool = False) -> list[str]:
    """What an explicit run warns about: inertia, added mass, hourglassing, one point.

    Args:
        led: The run's energy ledger.
        opts: Its explicit options (:class:`~forming.solver.options.ExplicitOptions`).
        mass_added: The mass scaling added, as a fraction of the mass.
        mass_limit: The added fraction above which a run is flagged.
        one_point_crushing: A crushable body has one point in plane per element
            (reduced or thickness integration): its crushing where it varies across an
            element is missed (docs/validation.md, "Where the core crushes").
    """
    out = []
    if led.ke_ie_max > opts.quasi_static_limit:
        out.append(f"explicit: kinetic energy reached {led.ke_ie_max:.1%} of the internal"
                   f" energy (quasi-static limit {opts.quasi_static_limit:.0%}): "
                   "inertia distorts the answer; lengthen explicit.loading_time")
    if mass_added > mass_limit:
        out.append(f"explicit: mass scaling added {mass_added:.1%} of the mass (above "
                   f"{mass_limit:.0%}); raise explicit.loading_time or lower "
                   "explicit.target_time_step")
    if led.hg_ie_max > opts.hourglass_limit:
        out.append(f"explicit: hourglass energy reached {led.hg_ie_max:.1%} of the "
                   f"internal energy (limit {opts.hourglass_limit:.0%}): refine the mesh, "
                   "raise explicit.hourglass or use explicit.integration=full")
    if one_point_crushing:
        share = {"reduced": "0-57%", "thickness": "38-61%"}.get(opts.integration, "part")
        out.append(f"explicit: integration={opts.integration} with a crushable core: one "
                   "point in plane does not crush where the crushing varies across an "
                   f"element (on the hemisphere {share} of the fully integrated crushed "
                   "volume, docs/validation.md); take crushing from "
                   "explicit.integration=full")
    return out
