"""Honeycomb geometry: hexagonal cells with thin walls, meshed as extruded hexahedra.

The cell follows Gibson & Ashby's notation turned so that the ribbon (the direction of
the bonded paper strips) lies along x: the *ribbon walls* (length ``h``) are parallel to
x and, in an expanded core, double (two bonded sheets, thickness ``2t``); the *inclined
walls* (length ``l``) make the angle ``theta`` with the y axis and are single (``t``).
The regular hexagon is ``h = l`` and ``theta = 30 deg``. The cell axis (the core's
thickness direction) is z.

The walls of a patch of ``nx`` x ``ny`` cells are the union of every cell's hexagon grown
by half the wall thickness, minus every cell's pore (its hexagon shrunk by half the wall
thickness), so the three walls of a junction meet with exact mitres and each wall has
its full thickness. The section is meshed with quadrilaterals and extruded along z.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np
from dolfinx import mesh as dmesh  # noqa: I001
from mpi4py import MPI

from forming import compat
from forming.errors import InputError
from forming.mesh import MeshData
from forming.meso.facets import facet_groups, group_names
from forming.parallel import on_root

WALL_DENSITY = 7.4e-10  # the cardboard walls' density, Table 1 [t/mm^3]


@dataclass(frozen=True)
class HoneycombCell:
    """The geometry of one honeycomb cell (mm, degrees).

    The defaults are the estimates of ``docs/materials.md`` for the paper's core (its
    cell dimensions appear only in its Fig. 3): regular hexagons, wall length 5 mm,
    wall thickness 0.30 mm, t/l = 0.06.

    Attributes:
        wall_length: Length ``l`` of the inclined (single) walls [mm].
        ribbon_length: Length ``h`` of the ribbon walls [mm]; None: equal to ``l``.
        wall_thickness: Thickness ``t`` of a single wall [mm].
        angle_deg: Angle ``theta`` of the inclined walls to the y axis [deg].
        double_walls: Whether the ribbon walls are two bonded sheets (``2t``).
    """

    wall_length: float = 5.0
    ribbon_length: float | None = None
    wall_thickness: float = 0.30
    angle_deg: float = 30.0
    double_walls: bool = True

    def __post_init__(self) -> None:
        for name in ("wall_length", "wall_thickness"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"cell.{name}", f"must be a positive length [mm], got {value!r}")
        if self.ribbon_length is not None and not (np.isfinite(self.ribbon_length)
                                                   and self.ribbon_length > 0):
            raise InputError("cell.ribbon_length",
                             f"must be a positive length [mm], got {self.ribbon_length!r}")
        if not (-60.0 < self.angle_deg < 60.0):
            raise InputError("cell.angle_deg", f"must lie in (-60, 60) degrees, got "
                             f"{self.angle_deg!r}")
        pore = self.pore(np.zeros(2))
        if _area(pore) <= 0 or not _convex(pore):
            raise InputError("cell.wall_thickness", f"{self.wall_thickness:g} mm walls "
                             "leave no pore in the cell: thinner walls or larger cells")

    @property
    def h(self) -> float:
        """Ribbon-wall length [mm]."""
        return self.wall_length if self.ribbon_length is None else self.ribbon_length

    @property
    def ribbon_thickness(self) -> float:
        """Thickness of a ribbon wall [mm]."""
        return self.wall_thickness * (2.0 if self.double_walls else 1.0)

    @property
    def pitch(self) -> tuple[float, float]:
        """Spacing of the cell centres: between columns (x) and along a column (y)."""
        th = math.radians(self.angle_deg)
        return self.h + self.wall_length * math.sin(th), 2.0 * self.wall_length * math.cos(th)

    @property
    def area(self) -> float:
        """Area of one cell in the plane [mm^2] (the lattice's area per cell)."""
        px, py = self.pitch
        return px * py

    def hexagon(self, centre: np.ndarray) -> np.ndarray:
        """The cell's wall mid-lines, (6, 2) vertices counter-clockwise from +x."""
        th = math.radians(self.angle_deg)
        a = self.h / 2 + self.wall_length * math.sin(th)
        b = self.wall_length * math.cos(th)
        v = np.array([[a, 0.0], [self.h / 2, b], [-self.h / 2, b],
                      [-a, 0.0], [-self.h / 2, -b], [self.h / 2, -b]])
        return v + np.asarray(centre, dtype=float)

    def edge_thickness(self) -> np.ndarray:
        """Thickness of the walls of :meth:`hexagon`'s edges, in its order."""
        t, r = self.wall_thickness, self.ribbon_thickness
        return np.array([t, r, t, t, r, t])

    def pore(self, centre: np.ndarray, shrink: float = 0.0) -> np.ndarray:
        """The open pore: the hexagon shrunk by half of each wall's thickness, and more."""
        return _offset(self.hexagon(centre), -self.edge_thickness() / 2 - shrink)

    def outline(self, centre: np.ndarray) -> np.ndarray:
        """The hexagon grown by half of each wall's thickness."""
        return _offset(self.hexagon(centre), self.edge_thickness() / 2)

    def relative_density(self) -> float:
        """Solid fraction of the infinite lattice (walls shared by two cells)."""
        return (self.area - _area(self.pore(np.zeros(2)))) / self.area


def cell_centres(cell: HoneycombCell, nx: int, ny: int) -> np.ndarray:
    """Centres of every cell whose walls reach an ``nx`` x ``ny`` patch's rectangle.

    Columns along x, odd columns shifted by half a pitch; one more cell on every side.
    """
    px, py = cell.pitch
    return np.array([[i * px, j * py + (i % 2) * py / 2]
                     for i in range(-1, nx + 2) for j in range(-1, ny + 2)])


def _offset(v: np.ndarray, d: np.ndarray) -> np.ndarray:
    """A convex polygon (counter-clockwise) with edge ``k`` moved outward by ``d[k]``."""
    n = len(v)
    lines = []
    for k in range(n):
        a, b = v[k], v[(k + 1) % n]
        t = (b - a) / np.linalg.norm(b - a)
        normal = np.array([t[1], -t[0]])  # outward for a counter-clockwise polygon
        lines.append((normal, float(normal @ a) + d[k]))
    out = np.empty_like(v)
    for k in range(n):  # vertex k joins edges k-1 and k
        (n0, c0), (n1, c1) = lines[k - 1], lines[k]
        out[k] = np.linalg.solve(np.array([n0, n1]), np.array([c0, c1]))
    return out


def _area(v: np.ndarray) -> float:
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _convex(v: np.ndarray) -> bool:
    e = np.roll(v, -1, axis=0) - v
    cross = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
    return bool(np.all(cross > 0))


@dataclass(frozen=True)
class HoneycombPatch:
    """A patch of honeycomb cells between two platens, and how to mesh it.

    Attributes:
        cell: The cell geometry.
        cells: Number of cells along x (columns) and y (rows).
        height: Core thickness along the cell axis z [mm].
        size: In-plane element size along the walls [mm]; None: twice the wall thickness.
        layers: Number of hexahedra along z.
        imperfection: Largest distance a node is moved in the plane by the seeded
            random imperfection [mm] (0: perfect walls).
        seed: Seed of the imperfection.
        infill: Whether the pores are meshed too (the paper's dummy infill, Table 3).
        flange: Width of a dummy flange along every wall's top edge, into the pores
            [mm] (0: none; the paper's dummy flanges, Table 3, our geometry).
        flange_thickness: Thickness of the flanges (the top layer of elements) [mm].
    """

    cell: HoneycombCell = HoneycombCell()
    cells: tuple[int, int] = (3, 3)
    height: float = 20.0
    size: float | None = None
    layers: int = 20
    imperfection: float = 0.0
    seed: int = 0
    infill: bool = False
    flange: float = 0.0
    flange_thickness: float = 0.3

    def __post_init__(self) -> None:
        if len(self.cells) != 2 or any(int(n) != n or n < 1 for n in self.cells):
            raise InputError("cells", f"must be two cell counts >= 1, got {self.cells}")
        if not (np.isfinite(self.height) and self.height > 0):
            raise InputError("height", f"must be a positive length [mm], got {self.height!r}")
        if self.size is not None and not (np.isfinite(self.size) and self.size > 0):
            raise InputError("size", f"must be a positive length [mm], got {self.size!r}")
        if int(self.layers) != self.layers or self.layers < 1:
            raise InputError("layers", f"must be an integer >= 1, got {self.layers!r}")
        if self.infill and self.flange > 0:
            raise InputError("flange", "a patch has either an infill or flanges, not both")
        if not (np.isfinite(self.flange) and self.flange >= 0):
            raise InputError("flange", f"must be a width >= 0 [mm], got {self.flange!r}")
        if self.flange > 0 and not (0 < self.flange_thickness < self.height):
            raise InputError("flange_thickness", f"must lie between 0 and the height, got "
                             f"{self.flange_thickness!r}")
        if not (np.isfinite(self.imperfection) and self.imperfection >= 0):
            raise InputError("imperfection", f"must be a length >= 0 [mm], got "
                             f"{self.imperfection!r}")

    def perturbed(self, x: np.ndarray, modes: int = 8) -> np.ndarray:
        """Node coordinates moved by the seeded random imperfection.

        The move is a smooth in-plane field (``modes`` plane waves of random direction
        and phase, wavelengths between one and three wall lengths, times
        ``sin(pi z / height)`` so that the walls' ends stay in the platens' planes),
        scaled so that the largest move is :attr:`imperfection`. A wall moves as a
        whole through its thickness, and the walls of a junction move together.
        """
        if self.imperfection == 0.0 or len(x) == 0:
            return x
        rng = np.random.default_rng(self.seed)
        lam = self.cell.wall_length * rng.uniform(1.0, 3.0, size=(2, modes))
        ang = rng.uniform(0.0, 2 * np.pi, size=(2, modes))
        elev = rng.uniform(-1.0, 1.0, size=(2, modes))
        phase = rng.uniform(0.0, 2 * np.pi, size=(2, modes))
        k = 2 * np.pi / lam
        kvec = np.stack([k * np.sqrt(1 - elev**2) * np.cos(ang),
                         k * np.sqrt(1 - elev**2) * np.sin(ang), k * elev], axis=-1)
        u = np.stack([np.cos(x @ kvec[c].T + phase[c]).sum(axis=1) for c in range(2)], axis=1)
        u *= np.sin(np.pi * x[:, 2:3] / self.height)
        u *= self.imperfection / np.max(np.linalg.norm(u, axis=1))
        y = x.copy()
        y[:, :2] += u
        return y

    @property
    def element_size(self) -> float:
        """In-plane element size [mm]."""
        return self.size if self.size is not None else 2.0 * self.cell.wall_thickness

    @property
    def footprint(self) -> float:
        """Nominal loaded area: the patch's rectangle, ``nx * ny`` cells' area [mm^2]."""
        return self.cells[0] * self.cells[1] * self.cell.area

    def wall_area(self) -> float:
        """Area of the walls' section [mm^2] (exact polygon arithmetic, no mesh)."""
        return section_area(self.cell, *self.cells)

    def relative_density(self) -> float:
        """Wall section over :attr:`footprint` (the lattice's value: the patch is a period)."""
        return self.wall_area() / self.footprint


def section_area(cell: HoneycombCell, nx: int, ny: int) -> float:
    """Area of the walls of a patch: its outline's area minus its pores' area."""
    with _gmsh_model("honeycomb_area") as gmsh:
        surface, _pores = _section(gmsh, cell, nx, ny)
        return float(sum(gmsh.model.occ.getMass(2, s) for s in surface))


@contextlib.contextmanager
def _gmsh_model(name: str):
    """A fresh gmsh model (gmsh started and stopped here if nobody else did)."""
    import gmsh

    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)
    try:
        yield gmsh
    finally:
        gmsh.model.remove()
        if not initialised:
            gmsh.finalize()


def _polygon(gmsh, v: np.ndarray) -> int:
    occ = gmsh.model.occ
    pts = [occ.addPoint(x, y, 0.0) for x, y in v]
    lines = [occ.addLine(pts[k], pts[(k + 1) % len(pts)]) for k in range(len(pts))]
    return occ.addPlaneSurface([occ.addCurveLoop(lines)])


def patch_box(cell: HoneycombCell, nx: int, ny: int) -> tuple[float, float, float, float]:
    """The patch's rectangle ``(x0, y0, width, depth)`` in the lattice of :func:`cell_centres`.

    Its sides along y pass through cell centres (they cut ribbon walls square at their
    middles), its sides along x through the middles of inclined walls (never through a
    junction); it holds exactly ``nx * ny`` cells' worth of walls.
    """
    px, py = cell.pitch
    return 0.0, py / 4, nx * px, ny * py


def _section(gmsh, cell: HoneycombCell, nx: int, ny: int, infill: bool = False,
             flange: float = 0.0) -> tuple[list[int], list[int]]:
    """Add the section in z = 0 to the OCC model; the walls' and the other surfaces' tags.

    The other surfaces are the pores (``infill``), or a ring of width ``flange`` inside
    each pore along its walls (flanges), or none; they share the walls' boundary curves
    (a conforming mesh).
    """
    occ = gmsh.model.occ
    centres = cell_centres(cell, nx, ny)
    outer = [(2, _polygon(gmsh, cell.outline(c))) for c in centres]
    pores = [(2, _polygon(gmsh, cell.pore(c))) for c in centres]
    outer, _ = occ.fuse(outer[:1], outer[1:])
    walls, _ = occ.cut(outer, pores)
    x0, y0, w, d = patch_box(cell, nx, ny)
    box = occ.addRectangle(x0, y0, 0.0, w, d)
    other: list[tuple[int, int]] = []
    if infill:
        other = [(2, occ.addRectangle(x0, y0, 0.0, w, d))]
    elif flange > 0:
        rings = [(2, _polygon(gmsh, cell.pore(c))) for c in centres]
        cores = [(2, _polygon(gmsh, cell.pore(c, flange))) for c in centres]
        rings, _ = occ.cut(rings, cores)
        other = occ.intersect(rings, [(2, occ.addRectangle(x0, y0, 0.0, w, d))])[0]
    walls, _ = occ.intersect(walls, [(2, box)])
    if other:
        other, _ = occ.cut(other, walls, removeTool=False)
        out, children = occ.fragment(walls, other)
        walls = [dt for kids in children[:len(walls)] for dt in kids]
        other = [dt for dt in out if dt not in walls]
    occ.synchronize()
    return [t for d_, t in walls if d_ == 2], [t for d_, t in other if d_ == 2]


def honeycomb_mesh(patch: HoneycombPatch, comm: MPI.Comm = MPI.COMM_WORLD) -> MeshData:
    """Mesh a honeycomb patch with hexahedra: quadrilaterals in the plane, layered in z.

    gmsh meshes the section with quadrilaterals only (each element of a first mesh
    split in four, so every element is a quadrilateral); the layers along z are stacked
    here, so that every hexahedron's edges along z are straight and the walls stay
    prismatic. The patch's imperfection moves the nodes after that.

    Groups: the volume ``walls``; the walls' faces ``bottom`` (z = 0) and ``top``
    (z = height); ``sides`` (every other boundary face), the union of ``wall_faces`` and
    the walls' cut faces on the patch's rectangle, ``cut_xmin``, ``cut_xmax`` (ribbon
    walls cut square at their middles) and ``cut_ymin``, ``cut_ymax`` (inclined walls cut
    at their middles; :func:`patch_box`), each with its part ``_inner`` at least a cell
    pitch from the rectangle's corners; ``top_sides``, the union of ``top`` and
    ``sides`` (what a tool pressed onto the walls meets once they fold), and
    ``bottom_sides`` likewise for a tool under them. With an infill
    also the volume ``infill``, its faces ``infill_bottom`` and ``infill_top``, and
    ``wall_infill``, the faces the walls share with the infill; with flanges the volume
    ``flange``, its top faces ``flange_top`` and ``wall_flange``.
    """
    def build() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        xy, quads, region = section_mesh(patch)
        z = np.linspace(0.0, patch.height, patch.layers + 1)
        if patch.flange > 0:  # a thin top layer: the flanges' thickness
            z = np.append(np.linspace(0.0, patch.height - patch.flange_thickness,
                                      patch.layers), patch.height)
        x, cells = extrude(xy, quads, z)
        region = np.tile(region, patch.layers)
        if patch.flange > 0:  # flanges only in the top layer
            top = np.repeat(np.arange(patch.layers) == patch.layers - 1, len(quads))
            keep = (region != 3) | top
            cells, region = cells[keep], region[keep]
            used, cells = np.unique(cells, return_inverse=True)
            x, cells = x[used], cells.reshape(-1, 8)
        return patch.perturbed(x), cells, region

    built = on_root(comm, build, gmsh_field="size")
    x, cells, region = built if built is not None else (
        np.zeros((0, 3)), np.zeros((0, 8), dtype=np.int64), None)
    region = comm.bcast(region, root=0)
    msh = compat.create_hex_mesh(comm, cells, x)
    tdim = msh.topology.dim
    cell_map = msh.topology.index_map(tdim)
    n_cells = cell_map.size_local + cell_map.num_ghosts
    cell_region = region[np.asarray(msh.topology.original_cell_index)[:n_cells]]
    cell_tags = dmesh.meshtags(msh, tdim, np.arange(n_cells, dtype=np.int32),
                               cell_region.astype(np.int32))
    facets, values = facet_groups(msh, cell_region, patch.height,
                                  patch_box(patch.cell, *patch.cells), patch.cell.pitch,
                                  patch.element_size)
    facet_tags = dmesh.meshtags(msh, tdim - 1, facets, values)
    names = {"walls": (3, 1), "bottom": (2, 1), "top": (2, 2), "wall_faces": (2, 3)}
    cuts, unions = group_names()
    names |= cuts
    # what a tool pressed onto the walls meets: their top edges, and their faces once
    # they fold under it
    unions["top_sides"] = (names["top"][1], *unions["sides"])
    unions["bottom_sides"] = (names["bottom"][1], *unions["sides"])
    if patch.infill:
        names |= {"infill": (3, 2), "infill_bottom": (2, 4), "infill_top": (2, 5),
                  "wall_infill": (2, 6)}
    if patch.flange > 0:
        names |= {"flange": (3, 3), "flange_top": (2, 7), "wall_flange": (2, 8)}
    return MeshData(msh, cell_tags, facet_tags, names, unions)


@contextlib.contextmanager
def _quad_options(size: float):
    """Options for an all-quadrilateral gmsh mesh of element size ``size / 2``.

    A frontal-Delaunay mesh of size ``size``, recombined, every element split in four.
    """
    import gmsh

    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.Algorithm", 8)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)
    try:
        yield
    finally:
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 0)
        gmsh.option.setNumber("Mesh.RecombineAll", 0)


def section_mesh(patch: HoneycombPatch) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quadrilateral mesh of the section: nodes (n, 2), quads (m, 4), their region (m,).

    Quadrilaterals are counter-clockwise; the region is 1 for a wall, 2 for the infill
    of a pore (with :attr:`HoneycombPatch.infill`), 3 for a flange.

    Raises:
        InputError: gmsh left elements other than quadrilaterals.
    """
    with _gmsh_model("honeycomb") as gmsh, _quad_options(2.0 * patch.element_size):
        walls, pores = _section(gmsh, patch.cell, *patch.cells, infill=patch.infill,
                                flange=patch.flange)
        gmsh.model.mesh.generate(2)
        elements, region = [], []
        for tag_value, surfaces in ((1, walls), (3 if patch.flange > 0 else 2, pores)):
            for surface in surfaces:
                types, _tags, nodes = gmsh.model.mesh.getElements(2, surface)
                if list(types) != [3]:  # 3: 4-node quadrilateral
                    names = sorted(gmsh.model.mesh.getElementProperties(t)[0] for t in types)
                    raise InputError("size", f"the honeycomb section did not mesh with "
                                     f"quadrilaterals alone ({names}); try another size")
                elements.append(np.asarray(nodes[0], dtype=np.int64))
                region.append(np.full(len(nodes[0]) // 4, tag_value))
        tags, coords, _p = gmsh.model.mesh.getNodes()
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    quads = index[np.concatenate(elements)].reshape(-1, 4)
    used, quads = np.unique(quads, return_inverse=True)
    quads = quads.reshape(-1, 4)
    xy = np.asarray(coords).reshape(-1, 3)[used, :2]
    p = xy[quads]
    area2 = np.sum(p[:, :, 0] * np.roll(p[:, :, 1], -1, axis=1)
                   - p[:, :, 1] * np.roll(p[:, :, 0], -1, axis=1), axis=1)
    quads[area2 < 0] = quads[area2 < 0][:, ::-1]
    return xy, quads, np.concatenate(region)


def extrude(xy: np.ndarray, quads: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stack a counter-clockwise quadrilateral mesh into hexahedra (gmsh node order).

    One layer of hexahedra between each two consecutive levels of ``z``.
    """
    n = len(xy)
    layers = len(z) - 1
    x = np.column_stack([np.tile(xy, (layers + 1, 1)), np.repeat(z, n)])
    cells = np.concatenate([np.hstack([quads + k * n, quads + (k + 1) * n])
                            for k in range(layers)])
    return x, cells.astype(np.int64)
