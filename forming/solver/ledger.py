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
IE_FLOOR = 0.05  # internal energy, as a share of its peak, below which no ratio counts


@dataclass
class EnergyLedger:
    """Energies [N mm] over all ranks at the last interval's end, and running maxima.

    Attributes:
        energy: kinetic, internal, friction, damping, external work and hourglass.
        ke_ie_max: Largest kinetic over internal energy, from 5% of the load on and
            where the internal energy is at least :data:`IE_FLOOR` of its largest so far
            (a cycle that passes through zero strain, as the picture frame's, has no
            internal energy to compare with there; the start of the load has none either).
        hg_ie_max: Largest hourglass over internal energy (the same rows).
        balance_max: Largest absolute energy balance.
        ie_peak: Largest internal energy so far [N mm].
    """

    energy: dict[str, float] = field(default_factory=lambda: dict.fromkeys(
        ("kinetic", "internal", "friction", "damping", "external", "hourglass"), 0.0))
    ke_ie_max: float = 0.0
    hg_ie_max: float = 0.0
    balance_max: float = 0.0
    ie_peak: float = 0.0
    _pending: np.ndarray = field(default_factory=lambda: np.zeros(len(_KEYS)))

    def add(self, internal: float, external: float, friction: float, damping: float) -> None:
        """Add one increment's works of this rank's nodes."""
        p = self._pending
        p[0] += internal
        p[1] += external
        p[2] += friction
        p[3] += damping

    def close_interval(self, comm: MPI.Comm, kinetic: float, hourglass: float,
                       load: float) -> None:
        """Sum the interval's works over ranks; record the energies and the maxima.

        Args:
            comm: The model's communicator.
            kinetic: Kinetic energy now (of this rank's nodes).
            hourglass: Hourglass energy now (of this rank's elements).
            load: Load parameter now.
        """
        local = np.concatenate([self._pending, [kinetic, hourglass]])
        total = np.zeros_like(local)
        comm.Allreduce(local, total, op=MPI.SUM)
        self._pending[:] = 0.0
        e = self.energy
        for key, value in zip(_KEYS, total[:4], strict=True):
            e[key] += float(value)
        e["kinetic"], e["hourglass"] = float(total[4]), float(total[5])
        ie = e["internal"]
        self.ie_peak = max(self.ie_peak, ie)
        if load >= 0.05 and ie > 0 and ie >= IE_FLOOR * self.ie_peak:
            self.ke_ie_max = max(self.ke_ie_max, e["kinetic"] / ie)
            self.hg_ie_max = max(self.hg_ie_max, e["hourglass"] / ie)
        self.balance_max = max(self.balance_max, abs(self.balance()))

    def balance(self) -> float:
        """Kinetic + internal + friction + damping - external work [N mm]."""
        e = self.energy
        return e["kinetic"] + e["internal"] + e["friction"] + e["damping"] - e["external"]

    def state(self) -> tuple:
        """Copy of the ledger (a snapshot)."""
        return (dict(self.energy), self.ke_ie_max, self.hg_ie_max, self.balance_max,
                self.ie_peak)

    def set_state(self, state: tuple) -> None:
        """Return to a snapshot."""
        energy, self.ke_ie_max, self.hg_ie_max, self.balance_max, *peak = state
        # (a checkpoint written before the peak was kept has four entries)
        self.ie_peak = peak[0] if peak else float(energy["internal"])
        self.energy = dict(energy)
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
