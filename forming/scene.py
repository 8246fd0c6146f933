"""The scene: what a case simulates, as frozen, validated dataclasses.

A scene names bodies (a mesh region and a material), prescribed displacements as
functions of the load parameter ``t`` in [0, 1], and nothing else unless the case
asks for it: the model builds only the terms the scene calls for.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from forming.errors import InputError
from forming.materials.fabric import NonCrimpFabric
from forming.materials.solids import SolidMaterial, check_density
from forming.mesh import MeshData
from forming.scene_contact import (  # noqa: F401  (the scene's public names)
    Contact,
    Interface,
    SelfContact,
    Sliding,
)


@dataclass(frozen=True)
class Linear:
    """Load path ``value(t) = total * t``."""

    total: float

    def __post_init__(self) -> None:
        if not math.isfinite(self.total):
            raise InputError("path.total", f"must be finite, got {self.total!r}")

    def __call__(self, t: float) -> float:
        """Value at load parameter ``t``."""
        return self.total * t


@dataclass(frozen=True)
class Table:
    """Piecewise-linear load path through ``(t, value)`` points, ``t`` from 0 to 1."""

    t: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.size < 2 or t.size != len(self.values):
            raise InputError("path.t", "needs at least two points and one value per point")
        if t[0] != 0.0 or t[-1] != 1.0 or np.any(np.diff(t) <= 0):
            raise InputError("path.t", f"must increase strictly from 0 to 1, got {self.t}")

    def __call__(self, t: float) -> float:
        """Value at load parameter ``t``."""
        return float(np.interp(t, self.t, self.values))


LoadPath = Linear | Table


@dataclass(frozen=True)
class Body:
    """A deformable solid.

    Attributes:
        name: Unique name, used in outputs.
        material: Its material (elastic, crushable foam, or a fabric layer).
        region: Volume physical group; ``None`` for the whole mesh.
        degree: Polynomial degree of the displacement.
        density: Mass density [tonne/mm^3] for explicit dynamics; None: the material's.
    """

    name: str
    material: SolidMaterial | NonCrimpFabric
    region: str | None = None
    degree: int = 1
    density: float | None = None

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise InputError("body.name", f"must be an identifier, got {self.name!r}")
        if self.degree not in (1, 2):
            raise InputError("body.degree", f"must be 1 or 2, got {self.degree!r}")
        check_density(self.density, "body.density")


@dataclass(frozen=True)
class Displacement:
    """Prescribed displacement components on a face of a body.

    A component left as ``None`` is free. A float holds it fixed at that value.

    Attributes:
        body: Name of the body.
        region: Surface physical group.
        x, y, z: Load paths (or constants) of the components [mm].
        reaction: Record the reaction force on this face each step.
    """

    body: str
    region: str
    x: LoadPath | float | None = None
    y: LoadPath | float | None = None
    z: LoadPath | float | None = None
    reaction: bool = True

    def __post_init__(self) -> None:
        if self.x is None and self.y is None and self.z is None:
            raise InputError(f"displacement[{self.region}]", "prescribes no component")

    def components(self) -> list[tuple[int, LoadPath | float]]:
        """(component index, path) for the prescribed components."""
        return [(i, p) for i, p in enumerate((self.x, self.y, self.z)) if p is not None]

    def value(self, component: int, t: float) -> float:
        """Prescribed value of ``component`` at load parameter ``t``."""
        p = (self.x, self.y, self.z)[component]
        return float(p) if isinstance(p, int | float) else p(t)


@dataclass(frozen=True)
class AffineDisplacement:
    """Displacement ``u = H(t) X`` prescribed (all components) on a face of a body.

    For kinematic fixtures that move the face as a whole, such as a pin-jointed picture
    frame (``H = F_frame(t) - I``) or clamps of a bias-extension specimen.

    Attributes:
        body: Name of the body.
        region: Surface physical group.
        gradient: ``H(t)``, a 3 x 3 displacement gradient at load parameter ``t``.
        components: The prescribed components (0, 1, 2 for x, y, z); the others are free.
    """

    body: str
    region: str
    gradient: Callable[[float], np.ndarray]
    components: tuple[int, ...] = (0, 1, 2)

    def __post_init__(self) -> None:
        if not self.components or not set(self.components) <= {0, 1, 2}:
            raise InputError(f"displacement[{self.region}].components",
                             f"must be a non-empty subset of (0, 1, 2), got {self.components}")
        h = np.asarray(self.gradient(0.0), dtype=float)
        if h.shape != (3, 3) or not np.all(np.isfinite(h)):
            raise InputError(f"displacement[{self.region}].gradient",
                             f"must return a finite 3 x 3 array, got shape {h.shape}")


@dataclass(frozen=True)
class Traction:
    """A dead traction on a face of a body, per unit reference area [MPa].

    Attributes:
        body: Name of the body.
        region: Surface physical group.
        x, y, z: Load paths (or constants) of the traction components [MPa].
    """

    body: str
    region: str
    x: LoadPath | float = 0.0
    y: LoadPath | float = 0.0
    z: LoadPath | float = 0.0

    def value(self, t: float) -> np.ndarray:
        """Traction vector at load parameter ``t``."""
        return np.array([float(p) if isinstance(p, int | float) else p(t)
                         for p in (self.x, self.y, self.z)])


@dataclass(frozen=True)
class Tool:
    """A rigid tool moved along a prescribed path.

    Attributes:
        name: Unique name, used in outputs (``force_<name>_z_N``).
        shape: Its shape in the initial position (see :mod:`forming.contact.shapes`).
        x, y, z: Displacement paths of the tool [mm]; ``None`` or 0 keeps it fixed.
    """

    name: str
    shape: object
    x: LoadPath | float | None = None
    y: LoadPath | float | None = None
    z: LoadPath | float | None = None

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise InputError("tool.name", f"must be an identifier, got {self.name!r}")

    def offset(self, t: float) -> np.ndarray:
        """Tool displacement at load parameter ``t``."""
        out = np.zeros(3)
        for i, p in enumerate((self.x, self.y, self.z)):
            if p is not None:
                out[i] = float(p) if isinstance(p, int | float) else p(t)
        return out


@dataclass(frozen=True)
class Stabilisation:
    """Viscous stabilisation of an implicit run through buckling and snap-through.

    A volume-proportional viscous force on the bodies, calibrated after the first step so
    that such a step would dissipate ``fraction`` of its strain energy (Abaqus's
    automatic stabilisation; theory.md). Implicit runs only.

    Attributes:
        fraction: Dissipated over strain energy of a step like the first (> 0, < 1).
        bodies: Names of the stabilised bodies (empty: all).
    """

    fraction: float = 2e-4
    bodies: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fraction) and 0 < self.fraction < 1):
            raise InputError("stabilisation.fraction", f"must lie in (0, 1), got "
                             f"{self.fraction!r}")


@dataclass(frozen=True)
class Scene:
    """Everything a solver needs to know about what is simulated.

    Attributes:
        name: Scene name.
        mesh: The mesh with named physical groups.
        bodies: The deformable bodies.
        displacements: Prescribed displacements.
        tractions: Dead tractions on faces.
        tools: Rigid tools.
        contacts: Contact pairs between body surfaces and tools.
        interfaces: Contact between bodies over their shared facets.
        sliding: Finite-sliding contact between bodies meshed apart.
        self_contacts: Surfaces of a body that may touch each other (folding walls).
        quadrature_degree: Quadrature degree of the bulk integrals (None: 2 for
            degree-1 bodies, 4 for degree 2, see ``docs/theory.md``).
        stabilisation: Viscous stabilisation of an implicit run (None: none).
        symmetry_copies: How many copies of the modelled part make the whole part (4
            for a quarter model with two symmetry planes). Whole-part forces, volumes
            and plots multiply by it; it is declared here once.
        travel: Travel of the load programme at load parameter 1 [mm] (the stroke); None:
            the largest travel of a tool or a prescribed face (:meth:`travel_mm`). It
            gives the history's ``stroke_mm`` column and the physical unit of a viscous
            regularisation (per mm of travel).
    """

    name: str
    mesh: MeshData
    bodies: tuple[Body, ...]
    displacements: tuple[Displacement | AffineDisplacement, ...] = ()
    tractions: tuple[Traction, ...] = ()
    tools: tuple[Tool, ...] = ()
    contacts: tuple[Contact, ...] = ()
    interfaces: tuple[Interface, ...] = ()
    sliding: tuple[Sliding, ...] = ()
    self_contacts: tuple[SelfContact, ...] = ()
    quadrature_degree: int | None = None
    stabilisation: Stabilisation | None = None
    symmetry_copies: int = 1
    travel: float | None = None
    metadata: dict = field(default_factory=dict, compare=False)

    def travel_mm(self) -> float | None:
        """Travel at load parameter 1 [mm]: the declared one, else the scene's largest.

        The scene's is the largest displacement at ``t = 1`` of a tool, or else of a
        prescribed face (None when neither moves, e.g. an affine fixture).
        """
        if self.travel is not None:
            return self.travel
        moves = [float(np.linalg.norm(t.offset(1.0))) for t in self.tools]
        if not any(moves):
            moves = [abs(d.value(c, 1.0)) for d in self.displacements
                     if isinstance(d, Displacement) for c, _p in d.components()]
        largest = max(moves, default=0.0)
        return largest if largest > 0 else None

    def __post_init__(self) -> None:
        if self.travel is not None and not (math.isfinite(self.travel) and self.travel > 0):
            raise InputError("scene.travel", f"must be a positive length [mm], got {self.travel}")
        if self.symmetry_copies not in (1, 2, 4, 8):
            raise InputError("scene.symmetry_copies",
                             f"must be 1, 2, 4 or 8, got {self.symmetry_copies!r}")
        names = [b.name for b in self.bodies]
        if not names:
            raise InputError("scene.bodies", "a scene needs at least one body")
        if len(set(names)) != len(names):
            raise InputError("scene.bodies", f"body names must be unique, got {names}")
        for b in self.bodies:
            if b.region is not None:
                self.mesh.cells(b.region)
            elif len(self.bodies) > 1:
                raise InputError(f"body[{b.name}].region",
                                 "each body of a scene with several bodies needs a region")
        def known(field_: str, who: str) -> None:
            if who not in names:
                raise InputError(field_, f"unknown body {who!r}; bodies: {names}")

        for itf in self.interfaces:
            known("interface.body", itf.body)
            known("interface.body", itf.other)
            self.mesh.facet_tag_ids(itf.region)
        for sl in self.sliding:
            known("sliding.master", sl.master)
            known("sliding.master", sl.slave)
            self.mesh.facet_tag_ids(sl.master_region)
            self.mesh.facet_tag_ids(sl.slave_region)
        for d in (*self.displacements, *self.tractions, *self.self_contacts):
            known(f"{type(d).__name__.lower()}.body", d.body)
            self.mesh.facet_tag_ids(d.region)
        tools = [t.name for t in self.tools]
        if len(set(tools)) != len(tools):
            raise InputError("scene.tools", f"tool names must be unique, got {tools}")
        for c in self.contacts:
            known("contact.body", c.body)
            if c.tool not in tools:
                raise InputError("contact.tool", f"unknown tool {c.tool!r}; tools: {tools}")
            self.mesh.facet_tag_ids(c.region)
        if self.stabilisation is not None:
            for who in self.stabilisation.bodies:
                known("stabilisation.bodies", who)

    def tool(self, name: str) -> Tool:
        """The tool called ``name``."""
        return next(t for t in self.tools if t.name == name)

    def body(self, name: str) -> Body:
        """The body called ``name``."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise InputError("body", f"unknown body {name!r}")
