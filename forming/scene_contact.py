"""The scene's contact specifications: tool contacts, interfaces, sliding, self-contact.

Frozen, validated dataclasses, re-exported by :mod:`forming.scene`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from forming.errors import InputError


def _nonnegative(spec, prefix: str, names: tuple[str, ...]) -> None:
    """Refuse a setting that is not a finite number >= 0."""
    for name in names:
        v = getattr(spec, name)
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"{prefix}.{name}", f"must be >= 0, got {v!r}")


def _positive_if_given(spec, prefix: str, names: tuple[str, ...]) -> None:
    """Refuse a given (not None) setting that is not a positive number."""
    for name in names:
        v = getattr(spec, name)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"{prefix}.{name}", f"must be positive, got {v!r}")


@dataclass(frozen=True)
class Contact:
    """Frictional contact between a surface region of a body and a tool.

    Attributes:
        body: Name of the body.
        region: Surface physical group that may touch the tool.
        tool: Name of the tool.
        friction: Coulomb coefficient (0: frictionless, no tangential terms compiled).
        penalty: Augmented-Lagrangian penalty [N/mm^3]; default 10 E / h from the body's
            largest elastic stiffness and the smallest surface edge.
        penalty_scale: Factor on the default penalty where multipliers enforce the
            contact (implicit runs). A multiplier update leaves about
            ``K / (K + penalty)`` of a penetration, ``K`` the stiffness behind the
            surface, so a stiffer penalty needs fewer updates. A fabric skin's ``E``
            (through its thickness) is far below what holds it against a tool (its
            tows, the crushed core), so its updates crawl (docs/theory.md, section 16).
            A penalty-only contact (explicit runs), whose penalty sets the penetration
            and the time step, keeps the default; a given ``penalty`` is taken as it is.
        tolerance: Admissible penetration [mm]; default 1% of the smallest surface edge
            or of the body's thickness, whichever is smaller.
        stick: How a sticking node is held: ``"augmented"`` (a stick constraint with
            Uzawa updates: no slip while sticking) or ``"elastic_slip"`` (a penalty of
            stiffness mu p / s_el with s_el = 0.5% of the facet edge, Abaqus' default;
            no Uzawa; the stiffness vanishes with the pressure, so nodes that touch at
            zero pressure, such as a fabric under a blank holder, do not cycle
            between stick and slip; docs/theory.md, section 11).
    """

    body: str
    region: str
    tool: str
    friction: float = 0.0
    penalty: float | None = None
    tolerance: float | None = None
    stick: Literal["augmented", "elastic_slip"] = "augmented"
    penalty_scale: float = 1.0

    def __post_init__(self) -> None:
        _nonnegative(self, "contact", ("friction",))
        if not (math.isfinite(self.penalty_scale) and self.penalty_scale > 0):
            raise InputError("contact.penalty_scale",
                             f"must be positive, got {self.penalty_scale!r}")
        if self.stick not in ("augmented", "elastic_slip"):
            raise InputError("contact.stick", f"must be 'augmented' or 'elastic_slip', "
                             f"got {self.stick!r}")
        _positive_if_given(self, "contact", ("penalty", "tolerance"))


@dataclass(frozen=True)
class Interface:
    """Contact between two bodies over the facets they share in the scene mesh.

    Small sliding: the surfaces are paired node to node as meshed (the nodes of the two
    bodies that start at the same point), so the tangential slip must stay well below an
    element size; the run warns when it does not (``docs/theory.md``, "Several bodies").

    Attributes:
        region: Surface physical group of shared (interior) facets, e.g.
            ``interface_top`` of a sandwich blank.
        body: The body whose outward normal is the contact normal (the core).
        other: The body on the other side (a skin).
        kind: ``"frictional"`` (separation allowed, Coulomb friction; ``friction = 0`` is
            frictionless and compiles no tangential terms) or ``"bonded"`` (tied).
        friction: Coulomb coefficient.
        penalty: Augmented-Lagrangian penalty [N/mm^3]; default 10 E / h from the
            first body's largest elastic stiffness and the smallest facet edge.
        tolerance: Admissible penetration [mm]; default 1% of the smallest facet edge or
            of the thinnest body, whichever is smaller.
        slip_warning: Warn when the tangential slip exceeds this fraction of the facet
            edge (the small-sliding pairing stops being accurate).
        stabilisation: Weak spring on the relative motion of the two surfaces within a
            load step, as a fraction of the penalty (0: none). It gives a skin that lifts
            off the core, which has almost no bending stiffness, a stiffness against
            floating; its force is recorded so its share can be checked.
        smoothing: Width of a smoothed pressure ramp, as a fraction of the pressure that
            the penetration tolerance stands for (penalty x tolerance); 0: sharp ramp.
            At zero gap it leaves a pressure of half the width.
    """

    region: str
    body: str
    other: str
    kind: str = "frictional"
    friction: float = 0.0
    penalty: float | None = None
    tolerance: float | None = None
    slip_warning: float = 0.5
    stabilisation: float = 0.0
    smoothing: float = 0.0

    def __post_init__(self) -> None:
        _nonnegative(self, "interface", ("stabilisation", "friction", "smoothing"))
        if self.kind not in ("frictional", "bonded"):
            raise InputError("interface.kind",
                             f"must be 'frictional' or 'bonded', got {self.kind!r}")
        if self.body == self.other:
            raise InputError("interface.other", f"must differ from body {self.body!r}")
        _positive_if_given(self, "interface", ("penalty", "tolerance", "slip_warning"))


@dataclass(frozen=True)
class Sliding:
    """Finite-sliding contact between two bodies meshed apart (non-matching surfaces).

    The slave region's nodes meet the master region's facets wherever they slide to
    (:mod:`forming.contact.sliding`); friction is Coulomb with elastic slip (in implicit
    runs; an explicit run holds a sticking node with the penalty).

    Attributes:
        name: Name used in history columns (``sliding_<name>_x_N``).
        master: The body whose facets carry the normal (a core).
        master_region: Its surface group.
        slave: The body whose nodes are constrained (a skin).
        slave_region: Its surface group.
        friction: Coulomb coefficient (0: frictionless).
        penalty: Augmented-Lagrangian penalty [N/mm^3]; default 10 E / h from the master's
            largest elastic stiffness and the shortest facet edge of either side.
        tolerance: Admissible penetration [mm]; default 1% of that edge or of the thinner
            body.
        transfer: How a slave node's force reaches the master: ``"area"`` spread over the
            node's tributary area (passes the contact patch test on non-matching meshes)
            or ``"point"`` at its closest point (classic node to surface, cheaper).
        stabilisation: A weak spring on each slave node's motion within a load step
            relative to the master point it began the step on, as a fraction of the
            penalty (0: none); its total force is recorded as
            ``sliding_<name>_stabilisation_N``. For nodes that open and close from one
            Newton iteration to the next.
        smoothing: Width of a smoothed pressure ramp (a parabola around zero trial
            pressure), as a fraction of the pressure the penetration tolerance stands for
            (penalty x tolerance); 0: the sharp ramp. At zero gap it leaves an eighth of
            the width; below a gap of half the width over the penalty, nothing.
        elastic_slip: The slip of a sticking node at the friction limit in implicit runs,
            as a fraction of the shortest facet edge (the stick stiffness is ``mu p /
            s_el``): smaller is closer to Coulomb's law, and Newton's path stiffer.
    """

    name: str
    master: str
    master_region: str
    slave: str
    slave_region: str
    friction: float = 0.0
    penalty: float | None = None
    tolerance: float | None = None
    transfer: Literal["area", "point"] = "area"
    stabilisation: float = 0.0
    smoothing: float = 0.0
    elastic_slip: float = 0.005

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise InputError("sliding.name", f"must be an identifier, got {self.name!r}")
        if self.master == self.slave:
            raise InputError("sliding.slave", f"must differ from master {self.master!r}")
        _nonnegative(self, "sliding", ("friction", "stabilisation", "smoothing"))
        if self.transfer not in ("area", "point"):
            raise InputError("sliding.transfer", f"must be 'area' or 'point', got "
                             f"{self.transfer!r}")
        _positive_if_given(self, "sliding", ("penalty", "tolerance", "elastic_slip"))


@dataclass(frozen=True)
class SelfContact:
    """A body's surface that may touch itself: cell walls folding onto each other.

    The explicit solver enforces it by penalty; an implicit run stops at the first step
    in which the surface meets itself (:mod:`forming.contact.selfcontact`).

    Attributes:
        body: The body (a solid of hexahedra).
        region: Its surface group whose faces may touch each other.
        depth: Search depth [mm], below the thinnest wall: a node deeper behind a face
            is the other side of its own wall; None: half the shortest edge of the
            surface's cells.
        stiffness: Explicit penalty over ``m / dt^2`` (``m`` the pair's reduced mass), in
            (0, 1].
        damping: Viscous contact damping, a fraction of the pair's critical damping
            (in [0, 1]).
    """

    body: str
    region: str
    depth: float | None = None
    stiffness: float = 0.3
    damping: float = 0.2

    def __post_init__(self) -> None:
        _positive_if_given(self, "self_contact", ("depth",))
        if not (math.isfinite(self.damping) and 0 <= self.damping <= 1):
            raise InputError("self_contact.damping", f"must lie in [0, 1], got "
                             f"{self.damping!r}")
        if not (math.isfinite(self.stiffness) and 0 < self.stiffness <= 1):
            raise InputError("self_contact.stiffness",
                             f"must lie in (0, 1], got {self.stiffness!r}")
