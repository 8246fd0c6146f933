"""Tool contact evaluated node by node, for the explicit solver's increments.

:class:`~forming.contact.terms.ContactTerm` integrates its traction with the vertex
rule, so its residual at a surface node is the node's traction times the node's share of
the reference surface area. :class:`NodalContact` evaluates exactly that, vectorised
over the region's owned nodes, without assembling a form: the gap and the normal come
from the tool's ``gap_normal`` (a difference of an analytic distance, or the closest
point on a surface mesh), the
pressure is the penalty's (the explicit solver leaves the multipliers at zero), and the
friction is the same Coulomb return with the same stick law. For an analytic tool the
increment's evaluation (:meth:`NodalContact.add_residual`) is one compiled loop over the
nodes (:mod:`forming.contact.nodalkernels`). Its frictional history
(the shear traction and the slip reference) lives in arrays here during a run, and is
written back to the contact's functions (:meth:`push`) for outputs and snapshots.
"""

from __future__ import annotations

import numpy as np

from forming.contact import nodalkernels
from forming.contact.shapes import AnalyticShape

_TINY = 1e-30
_SLACK = 1e-12  # stick test slack [MPa], as the forms


def critical_damping(zeta: float, penalty: float, areal_mass: np.ndarray) -> np.ndarray:
    """Normal damping ``c = 2 zeta sqrt(eps m/A)`` [MPa s/mm] of a node on a penalty spring.

    Args:
        zeta: Fraction of critical damping.
        penalty: The penalty ``eps`` [N/mm^3].
        areal_mass: The node's mass over its area ``m/A`` [t/mm^2].
    """
    return 2.0 * zeta * np.sqrt(penalty * areal_mass)


class NodalContact:
    """Penalty contact of a region's owned nodes with a rigid tool.

    Args:
        shape: The tool's shape (:mod:`forming.contact.shapes`,
            :mod:`forming.contact.surface`).
        nodes: Owned region nodes (block indices of the body's displacement space).
        coords: (n, 3) reference coordinates of those nodes.
        area: (n,) reference surface area of each node (vertex rule) [mm^2].
        penalty: Normal penalty [N/mm^3].
        friction: Coulomb coefficient (0: no tangential terms). A sticking node is held by
            the normal penalty (explicit runs: a stick stiffness that follows a ringing
            pressure ratchets the traction history down, docs/theory.md section 12).
    """

    def __init__(self, shape, nodes: np.ndarray, coords: np.ndarray, area: np.ndarray,
                 penalty: float, friction: float):
        self.shape = shape
        self._tracker = shape.tracker()
        self.nodes = nodes
        self.dofs = (3 * nodes[:, None] + np.arange(3)).ravel()
        self.coords = coords
        self.area = area
        self.penalty = penalty
        self.friction = friction
        n = len(nodes)
        self.r = np.zeros((n, 3))  # residual at the nodes: minus area times traction
        self.r_old = np.zeros((n, 3))
        self.shear = np.zeros((n, 3))  # shear traction of the last evaluation
        self.lam_t = np.zeros((n, 3))  # converged shear traction
        self.u_prev = np.zeros((n, 3))  # slip reference: displacement at the last commit
        self.offset_prev = np.zeros(3)
        # the compiled loop's code and parameters of an analytic shape (None: NumPy)
        self._code = shape.kernel_code() if isinstance(shape, AnalyticShape) else None

    def residual(self, u: np.ndarray, offset: np.ndarray,
                 damping: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """Residual entries of the contact at its nodes, (n, 3); kept as :attr:`r`.

        Args:
            u: The body's displacement array (3 per node).
            offset: The tool's current displacement [mm].
            damping: ``(c, v)``: a viscous pressure ``-c v . n`` joins the penalty's, ``c``
                [MPa s/mm] per node and ``v`` (n, 3) the nodes' velocities relative to the
                tool (the pressure stays compressive; friction follows it).
        """
        self.r_old[:] = self.r
        un = u.reshape(-1, 3)[self.nodes]
        gap, normal = self._tracker.gap_normal(self.coords + un - offset)
        trial = -self.penalty * gap
        if damping is not None:
            c, v = damping
            trial -= c * np.sum(v * normal, axis=1) * (gap < 0)
        pressure = np.maximum(trial, 0.0)
        traction = pressure[:, None] * normal
        if self.friction > 0.0:
            slip = un - self.u_prev - (offset - self.offset_prev)
            slip -= np.sum(slip * normal, axis=1)[:, None] * normal
            lam = self.lam_t - np.sum(self.lam_t * normal, axis=1)[:, None] * normal
            limit = self.friction * pressure
            trial = lam - self.penalty * slip
            size = np.sqrt(np.sum(trial * trial, axis=1) + _TINY)
            scale = np.where(size <= limit + _SLACK, 1.0, limit / size)
            np.multiply(trial, scale[:, None], out=self.shear)
            traction += self.shear
        np.multiply(traction, -self.area[:, None], out=self.r)
        return self.r

    def add_residual(self, u: np.ndarray, offset: np.ndarray, f_all: np.ndarray,
                     damping: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        """Evaluate as :meth:`residual` and add the result to a body's residual array.

        Args:
            u: The body's displacement array (3 per node).
            offset: The tool's current displacement [mm].
            f_all: The body's residual array (entries of the nodes' dofs grow).
            damping: ``(c, v, w)``: the normal damping [MPa s/mm] per node, the body's
                velocity array and the tool's velocity [mm/s]; None: undamped.
        """
        if self._code is None:
            v_rel = None
            if damping is not None:
                c, v, w = damping
                v_rel = (c, v.reshape(-1, 3)[self.nodes] - w)
            f_all[self.dofs] += self.residual(u, offset, v_rel).ravel()
            return
        kind, q = self._code
        c, v, w = damping if damping is not None else nodalkernels.NO_DAMPING
        nodalkernels.contact_residual(kind, q, u, self.nodes, self.coords, self.area,
                                      np.asarray(offset, dtype=float), self.penalty,
                                      self.friction, c, v, w, self.lam_t, self.u_prev,
                                      self.offset_prev, self.shear, self.r, self.r_old, f_all)

    def repair(self) -> None:
        """Search a surface-mesh tool's tree again at the next evaluation."""
        self._tracker.repair()

    def commit(self, u: np.ndarray, offset: np.ndarray) -> None:
        """Accept the increment: the shear becomes history, slip is measured from here."""
        if self.friction > 0.0:
            nodalkernels.commit_slip(u, self.nodes, self.shear, self.lam_t, self.u_prev)
            self.offset_prev[:] = offset

    def force_on_tool(self) -> np.ndarray:
        """Mean force of this rank's nodes on the tool over the last increment [N]."""
        return 0.5 * (self.r_old + self.r).sum(axis=0)
