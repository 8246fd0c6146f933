"""Blanks for a scene: a core alone, or a sandwich of a core between two fabric skins.

A :class:`Blank` holds the mesh, the bodies and the skin-core interfaces of a blank,
where its top and bottom faces are, and which bodies the upper and lower tools touch,
so that a case builds its tooling around it without knowing which kind it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from forming.errors import InputError
from forming.materials.fabric import NonCrimpFabric
from forming.mesh import Block, MeshData, blocks, box
from forming.partition import Partition
from forming.scene import Body, Displacement, Interface, Sliding

SKINS = ("skin_bottom", "skin_top")


@dataclass(frozen=True)
class Blank:
    """The bodies of a blank and where the tools meet it.

    Attributes:
        mesh: Its mesh.
        bodies: Its bodies (the core first).
        interfaces: Skin-core interfaces (none for a core alone).
        top: z of its top face [mm].
        bottom: z of its bottom face [mm].
        upper: Body whose ``top`` face the upper tools touch.
        lower: Body whose ``bottom`` face the lower tools touch.
        sliding: Finite-sliding skin-core contacts (skins meshed apart from the core).
        prefixed: The mesh names each body's faces ``<body>_<face>``
            (:func:`forming.mesh.blocks`), not once for the whole blank.
    """

    mesh: MeshData
    bodies: tuple[Body, ...]
    interfaces: tuple[Interface, ...]
    top: float
    bottom: float
    upper: str
    lower: str
    sliding: tuple[Sliding, ...] = ()
    prefixed: bool = False

    def face(self, body: str, name: str) -> str:
        """The surface group of ``body``'s face ``name`` (``top``, ``xmin``, ...)."""
        return f"{body}_{name}" if self.prefixed else name

    @property
    def skins(self) -> tuple[str, ...]:
        """Names of its fabric skins (empty for a core alone)."""
        return tuple(b.name for b in self.bodies if isinstance(b.material, NonCrimpFabric))

    def symmetry(self, planes: tuple[tuple[str, str], ...] = (("xmin", "x"), ("ymin", "y"))
                 ) -> tuple[Displacement, ...]:
        """Symmetry conditions of every body on the planes ``(face, normal component)``."""
        return tuple(Displacement(b.name, self.face(b.name, face), **{axis: 0.0},
                                  reaction=False)
                     for b in self.bodies for face, axis in planes)


def core_blank(mesh: MeshData, core, thickness: float) -> Blank:
    """A core alone, on the whole mesh, from z = 0 to ``thickness``."""
    return Blank(mesh, (Body("core", core),), (), thickness, 0.0, "core", "core")


def sandwich(mesh: MeshData, core, fabric: NonCrimpFabric, core_thickness: float,
             plies: int = 1, kind: str = "frictional", friction: float = 0.0,
             stabilisation: float = 0.0, smoothing: float = 0.0) -> Blank:
    """A core between a bottom and a top skin on a sandwich mesh (:mod:`forming.sandwich`).

    Args:
        mesh: The sandwich mesh (volume groups ``core``, ``skin_bottom``, ``skin_top``).
        core: The core's material.
        fabric: The skins' material (its thickness is the ply thickness).
        core_thickness: Core thickness [mm].
        plies: Plies per skin.
        kind: ``"frictional"`` or ``"bonded"`` skin-core interfaces.
        friction: Skin-core Coulomb coefficient.
        stabilisation: Interface stabilisation (fraction of the penalty).
        smoothing: Smoothed interface pressure ramp (fraction).
    """
    bodies = (Body("core", core, region="core"), *(Body(s, fabric, region=s) for s in SKINS))
    interfaces = tuple(Interface(f"interface_{side}", "core", f"skin_{side}", kind=kind,
                                 friction=friction, stabilisation=stabilisation,
                                 smoothing=smoothing) for side in ("bottom", "top"))
    top = core_thickness + 2 * plies * fabric.thickness
    return Blank(mesh, bodies, interfaces, top, 0.0, "skin_top", "skin_bottom")


@dataclass(frozen=True)
class Skins:
    """Fabric skins on both faces of a core, sliding on it.

    Attributes:
        fabric: The skins' material (its thickness is the ply thickness).
        plies: Plies per skin.
        friction: Skin-core Coulomb coefficient (paper: 0.52).
        stabilisation: Interface stabilisation (fraction of the penalty).
        smoothing: Smoothed interface pressure ramp (fraction).
        contact: ``"small"``: one conforming mesh, skin and core nodes paired as meshed
            (small sliding); ``"finite"``: the skins meshed apart and sliding any
            distance on the core (node to surface, :mod:`forming.contact.sliding`).
        refinement: With finite sliding, skin elements per core element along each
            in-plane direction.
        transfer: With finite sliding, how a skin node's force reaches the core
            (:class:`~forming.scene.Sliding`: ``"area"`` or ``"point"``).
        elastic_slip: With finite sliding, the implicit stick law's slip at the friction
            limit, as a fraction of the shortest facet edge (:class:`~forming.scene.Sliding`).
    """

    fabric: NonCrimpFabric
    plies: int = 1
    friction: float = 0.52
    stabilisation: float = 0.0
    smoothing: float = 0.0
    contact: Literal["small", "finite"] = "small"
    refinement: int = 1
    transfer: Literal["area", "point"] = "area"
    elastic_slip: float = 0.005

    def __post_init__(self) -> None:
        if self.contact not in ("small", "finite"):
            raise InputError("skin_contact", f"must be 'small' or 'finite', got "
                             f"{self.contact!r}")
        if int(self.refinement) != self.refinement or self.refinement < 1:
            raise InputError("skin_refinement", f"must be an integer >= 1, got "
                             f"{self.refinement!r}")


def rectangular_blank(half_x: float, half_y: float, thickness: float, cells: tuple[int, ...],
                      core, skins: Skins | None = None, grading: float = 1.0,
                      partition: Partition = "graph") -> Blank:
    """A quarter of a rectangular blank, ``[0, half_x] x [0, half_y]``: core or sandwich.

    Args:
        half_x: Half length of the blank along x [mm].
        half_y: Half length of the blank along y [mm].
        thickness: Core thickness [mm].
        cells: Elements along x, y and through the core.
        core: The core's material.
        skins: Skins on both faces; None: the core alone.
        grading: In-plane element growth away from the centre (core alone only).
        partition: How the cells are shared among the ranks (:mod:`forming.partition`).

    Raises:
        InputError: With skins, ``cells`` does not give square elements in plane.
    """
    if skins is None:
        mesh = box((half_x, half_y, thickness), tuple(cells), grading=(grading, grading, 1.0),
                   partition=partition)
        return core_blank(mesh, core, thickness)
    if skins.contact == "finite":
        return _sliding_sandwich(half_x, half_y, thickness, cells, core, skins, partition)
    element = half_x / cells[0]
    if round(half_y / element) != cells[1]:
        raise InputError("cells", f"with skins the in-plane mesh is square: got {cells}")
    from forming.sandwich import Outline, sandwich_blank

    mesh = sandwich_blank(Outline.rectangle(half_x, half_y), core_thickness=thickness,
                          skin_thickness=skins.fabric.thickness, plies=skins.plies,
                          element_size=element, core_layers=cells[2], partition=partition)
    return sandwich(mesh, core, skins.fabric, thickness, skins.plies, friction=skins.friction,
                    stabilisation=skins.stabilisation, smoothing=skins.smoothing)


def _sliding_sandwich(half_x: float, half_y: float, thickness: float, cells, core,
                      skins: Skins, partition: Partition = "graph") -> Blank:
    """Core and skins as separate blocks (no shared nodes), the skins sliding on the core."""
    t = skins.plies * skins.fabric.thickness
    r = int(skins.refinement)
    nx, ny, nz = (int(c) for c in cells)
    mesh = blocks([
        Block("skin_bottom", (half_x, half_y, t), (r * nx, r * ny, skins.plies)),
        Block("core", (half_x, half_y, thickness), (nx, ny, nz), origin=(0.0, 0.0, t)),
        Block("skin_top", (half_x, half_y, t), (r * nx, r * ny, skins.plies),
              origin=(0.0, 0.0, t + thickness)),
    ], partition=partition)
    return _sliding_blank(mesh, thickness, core, skins)


def _sliding_blank(mesh: MeshData, thickness: float, core, skins: Skins) -> Blank:
    """The blank of a mesh whose core and skins share no nodes, the skins sliding on it."""
    t = skins.plies * skins.fabric.thickness
    bodies = (Body("core", core, region="core"),
              *(Body(s, skins.fabric, region=s) for s in SKINS))
    sliding = tuple(Sliding(side, "core", f"core_{side}", f"skin_{side}",
                            f"skin_{side}_{'top' if side == 'bottom' else 'bottom'}",
                            friction=skins.friction, transfer=skins.transfer,
                            stabilisation=skins.stabilisation, smoothing=skins.smoothing,
                            elastic_slip=skins.elastic_slip)
                    for side in ("bottom", "top"))
    return Blank(mesh, bodies, (), thickness + 2 * t, 0.0, "skin_top", "skin_bottom",
                 sliding=sliding, prefixed=True)


def outline_blank(outline, thickness: float, element_size: float, core_layers: int, core,
                  skins: Skins | None = None) -> Blank:
    """A blank of any outline (:class:`~forming.outline.Outline`): core or sandwich.

    With finitely sliding skins each body is meshed on its own
    (:func:`forming.layered.sliding_sandwich_mesh`, skins ``skins.refinement`` times
    finer); with small sliding, one conforming mesh (:func:`forming.sandwich.sandwich_blank`).
    """
    from forming.sandwich import sandwich_blank

    if skins is None:
        mesh = sandwich_blank(outline, core_thickness=thickness, plies=0,
                              element_size=element_size, core_layers=core_layers)
        return core_blank(mesh, core, thickness)
    if skins.contact == "finite":
        from forming.layered import sliding_sandwich_mesh

        mesh = sliding_sandwich_mesh(outline, thickness, skins.fabric.thickness, skins.plies,
                                     element_size, core_layers, skins.refinement)
        return _sliding_blank(mesh, thickness, core, skins)
    mesh = sandwich_blank(outline, core_thickness=thickness,
                          skin_thickness=skins.fabric.thickness, plies=skins.plies,
                          element_size=element_size, core_layers=core_layers)
    return sandwich(mesh, core, skins.fabric, thickness, skins.plies, friction=skins.friction,
                    stabilisation=skins.stabilisation, smoothing=skins.smoothing)
