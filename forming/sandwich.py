"""Sandwich blanks: a core between two skins as one conforming hexahedral mesh.

The blank is a planar outline extruded along +z in layers: the plies of the bottom
skin, the core, the plies of the top skin. Each ply is one element thick. The bodies
share the nodes of their interfaces, so each body can be put on its own cell submesh
(``dolfinx.mesh.create_submesh``) and the bodies coupled on the shared facets.

Facet groups and overlaps:
    A DOLFINx ``MeshTags`` holds one value per facet, so facets in two gmsh physical
    groups keep only one of them. The facet groups written to gmsh are therefore
    disjoint (every facet has exactly one tag). Groups that overlap others (``edge``
    contains ``core_edge`` and ``xmin``) are unions of these disjoint groups:
    :meth:`SandwichMesh.facets` returns their facets and
    :meth:`SandwichMesh.facet_tag_ids` the tags for ``ds(subdomain_id=...)``. A union
    made of a single disjoint group is also in ``names`` (an alias with the same tag).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from forming.errors import InputError
from forming.mesh import MeshData, mesh_from_gmsh
from forming.outline import Outline, check_integer, check_positive
from forming.parallel import on_root
from forming.partition import Partition

log = logging.getLogger(__name__)

BODIES = ("skin_bottom", "core", "skin_top")
"""Volume groups from bottom to top (the skins only when ``plies > 0``)."""

CELL_TAGS = {"core": 1, "skin_bottom": 2, "skin_top": 3}
"""Tag of each volume group."""

_GMSH_QUAD = 3  # gmsh element type of a 4-node quadrilateral
_GMSH_HEX = 5  # gmsh element type of an 8-node hexahedron


@dataclass(frozen=True)
class SandwichMesh(MeshData):
    """A :class:`~forming.mesh.MeshData` of a sandwich blank with overlapping facet groups.

    Attributes:
        layers: (body, z_bottom, z_top) of every extruded layer from the bottom up;
            a skin has one entry per ply, so the ply boundaries are recorded here.

    Its ``unions`` (:class:`~forming.mesh.MeshData`): ``edge``, ``free_edge``,
    ``core_edge``, ``skin_bottom_edge``, ``skin_top_edge``, ``xmin``, ``ymin``.
    """

    layers: tuple[tuple[str, float, float], ...] = ()

    def owned_cell_count(self, name: str) -> int:
        """Number of cells of the volume group ``name`` over all ranks."""
        n_local = self.mesh.topology.index_map(3).size_local
        cells = self.cells(name)
        return self.mesh.comm.allreduce(int(np.sum(cells < n_local)), op=MPI.SUM)


def _layer_heights(n: int, grading: float) -> list[float]:
    """Cumulative heights (fractions) of ``n`` layers graded symmetrically about the middle."""
    sizes = np.array([grading ** min(i, n - 1 - i) for i in range(n)])
    return list(np.cumsum(sizes) / sizes.sum())


_OPTIONS = {
    "Mesh.Algorithm": 8,  # Frontal-Delaunay for quads
    "Mesh.RecombinationAlgorithm": 3,  # blossom full-quad
    "Mesh.RecombineAll": 0,
    "Mesh.SubdivisionAlgorithm": 0,
    "Mesh.ElementOrder": 1,
    "Mesh.MeshSizeFactor": 1.0,
    "Mesh.MeshSizeFromPoints": 1,
    "Mesh.MeshSizeFromCurvature": 0,
    "Mesh.MeshSizeExtendFromBoundary": 1,
}


def _build(gmsh, outline: Outline, layers: list[tuple[str, float, int, list[float]]],
           h: float, structured: bool) -> tuple[dict, dict]:
    """Geometry, physical groups and mesh of the blank in the current gmsh model.

    Returns:
        The disjoint facet groups (name -> tag) and the unions (name -> names).
    """
    geo = gmsh.model.geo
    pts = np.asarray(outline.points)
    ptags = [geo.addPoint(x, y, 0.0, h) for x, y in pts]
    if outline.kind == "spline":
        curves = [geo.addSpline(ptags + [ptags[0]])]
    else:
        curves = [geo.addLine(ptags[i], ptags[(i + 1) % len(ptags)]) for i in range(len(ptags))]
    base = geo.addPlaneSurface([geo.addCurveLoop(curves)])

    volumes: dict[str, list[int]] = {b: [] for b in BODIES}
    lateral: dict[str, list[int]] = {b: [] for b in BODIES}
    horizontal: dict[str, list[int]] = {"bottom": [base]}
    current = [(2, base)]
    for k, (body, height, n, cum) in enumerate(layers):
        out = geo.extrude(current, 0.0, 0.0, height, numElements=[1] * n, heights=cum,
                          recombine=True)
        top, vol = out[0], out[1]
        volumes[body].append(vol[1])
        lateral[body].extend(t for d, t in out[2:] if d == 2)
        above = layers[k + 1][0] if k + 1 < len(layers) else None
        if above is None:
            group = "top"
        elif above != body:
            group = "interface_bottom" if body == "skin_bottom" else "interface_top"
        else:
            group = "ply_interface_" + body.removeprefix("skin_")
        horizontal.setdefault(group, []).append(top[1])
        current = [top]
    geo.synchronize()

    if structured:
        lengths = np.linalg.norm(pts - np.roll(pts, -1, axis=0), axis=1)
        for i, c in enumerate(curves):
            n = max(1, round(max(lengths[i], lengths[(i + 2) % 4]) / h))
            gmsh.model.mesh.setTransfiniteCurve(c, n + 1)
        gmsh.model.mesh.setTransfiniteSurface(base, "Left", ptags)
    gmsh.model.mesh.setRecombine(2, base)

    # Lateral faces on the symmetry planes x = xmin, y = ymin of the outline.
    xmin, ymin, xmax, ymax = outline.bounds
    tol = 1e-7 * max(xmax - xmin, ymax - ymin)
    planes = {"xmin": (0, xmin), "ymin": (1, ymin)}
    atoms: dict[str, list[int]] = dict(horizontal)
    for body in BODIES:
        for s in lateral[body]:
            bb = gmsh.model.getBoundingBox(2, s)
            where = "free"
            for pname, (axis, value) in planes.items():
                if abs(bb[axis + 3] - bb[axis]) <= tol and abs(bb[axis] - value) <= tol:
                    where = pname
            atoms.setdefault(f"{body}_edge_{where}", []).append(s)

    for body in BODIES:
        if volumes[body]:
            gmsh.model.addPhysicalGroup(3, volumes[body], CELL_TAGS[body], name=body)
    order = ["bottom", "top", "interface_bottom", "interface_top", "ply_interface_bottom",
             "ply_interface_top"]
    order += [f"{b}_edge_{w}" for b in BODIES for w in ("free", "xmin", "ymin")]
    facet_groups = {}
    for name in order:
        if name in atoms:
            tag = len(facet_groups) + 1
            gmsh.model.addPhysicalGroup(2, atoms[name], tag, name=name)
            facet_groups[name] = tag
    laterals = [n for n in facet_groups if "_edge_" in n]
    unions = {
        "edge": laterals,
        "free_edge": [n for n in laterals if n.endswith("_free")],
        "xmin": [n for n in laterals if n.endswith("_xmin")],
        "ymin": [n for n in laterals if n.endswith("_ymin")],
    }
    for body in BODIES:
        unions[f"{body}_edge"] = [n for n in laterals if n.startswith(f"{body}_edge_")]
    unions = {k: v for k, v in unions.items() if v}

    _generate(gmsh, base)
    return facet_groups, unions


def _generate(gmsh, base: int) -> None:
    """Mesh the model; all-quadrilateral in plane (else retry, then fail), all-hexahedral."""
    for algorithm in (3, 2):  # blossom full-quad, then simple full-quad
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", algorithm)
        gmsh.model.mesh.generate(2)
        types, tags, _ = gmsh.model.mesh.getElements(2, base)
        n_other = sum(len(t) for ty, t in zip(types, tags, strict=True) if ty != _GMSH_QUAD)
        if n_other == 0:
            break
        log.debug("recombination algorithm %d left %d non-quadrilaterals", algorithm, n_other)
        gmsh.model.mesh.clear()
    else:
        raise InputError(
            "mesh.outline",
            f"gmsh left {n_other} triangles in the in-plane mesh; try another element_size "
            "or a simpler outline",
        )
    quads = tags[0]
    quality = gmsh.model.mesh.getElementQualities(quads, "minSJ")
    if quality.min() <= 0.0:
        raise InputError("mesh.outline", "gmsh produced inverted quadrilaterals")
    if quality.min() < 0.2:
        log.warning("poorly shaped quadrilaterals: min scaled Jacobian %.3f", quality.min())
    gmsh.model.mesh.generate(3)
    types, tags, _ = gmsh.model.mesh.getElements(3)
    bad = {ty: len(t) for ty, t in zip(types, tags, strict=True) if ty != _GMSH_HEX}
    if bad:
        raise RuntimeError(f"extrusion produced non-hexahedral elements {bad}")


def sandwich_blank(
    outline: Outline,
    core_thickness: float = 20.0,
    skin_thickness: float = 0.4,
    plies: int = 1,
    element_size: float = 10.0,
    core_layers: int = 4,
    grading: float = 1.0,
    structured: bool | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    name: str = "sandwich",
    partition: Partition = "graph",
) -> SandwichMesh:
    """Hexahedral mesh of a core between a bottom and a top skin of ``plies`` plies each.

    z runs from 0: the bottom skin occupies [0, plies*t], the core
    [plies*t, plies*t + H] and the top skin the next plies*t. Every ply is one element
    thick; the core has ``core_layers`` elements through its thickness.

    Volume groups: ``core``, ``skin_bottom``, ``skin_top`` (the skins when
    ``plies > 0``). Disjoint facet groups: ``bottom``, ``top``, ``interface_bottom``
    and ``interface_top`` (core/skin facets, interior facets), ``ply_interface_bottom``
    and ``ply_interface_top`` (ply/ply facets, ``plies > 1``), and lateral faces
    ``<body>_edge_<free|xmin|ymin>``. Unions (see :class:`SandwichMesh`): ``edge`` (all
    lateral faces), ``free_edge`` (not on a symmetry plane), ``core_edge``,
    ``skin_bottom_edge``, ``skin_top_edge``, ``xmin`` and ``ymin`` (lateral faces of
    all layers on x = xmin / y = ymin of the outline; only when a polygon edge lies
    there: symmetry planes of a quarter model).

    Args:
        outline: Blank outline in the x-y plane.
        core_thickness: Core thickness H [mm].
        skin_thickness: Thickness t of one ply [mm] (ignored when ``plies == 0``).
        plies: Plies per skin; 0 gives the core alone.
        element_size: In-plane element size [mm], at most the outline's smaller extent.
        core_layers: Elements through the core thickness.
        grading: Ratio of consecutive core layer thicknesses from each skin towards the
            mid-plane (1: uniform, > 1: finer next to the skins).
        structured: Transfinite (structured) in-plane mesh; None: when the outline is a
            convex quadrilateral. True needs a convex 4-corner polygon.
        comm: Communicator of the mesh (built on rank 0, then distributed).
        name: Name of the gmsh model.
        partition: How the cells are shared among the ranks (:mod:`forming.partition`).

    Returns:
        The mesh, its tags and its named groups.

    Raises:
        InputError: Invalid parameter, or gmsh could not mesh the outline with
            quadrilaterals only.
    """
    if not isinstance(outline, Outline):
        raise InputError("mesh.outline", f"must be an Outline, got {type(outline).__name__}")
    H = check_positive("mesh.core_thickness", core_thickness)
    plies = check_integer("mesh.plies", plies, 0)
    t = check_positive("mesh.skin_thickness", skin_thickness) if plies else 0.0
    h = check_positive("mesh.element_size", element_size)
    xmin, ymin, xmax, ymax = outline.bounds
    extent = min(xmax - xmin, ymax - ymin)
    if h > extent:
        raise InputError(
            "mesh.element_size",
            f"{h} is larger than the outline's smallest extent {extent:g}",
        )
    core_layers = check_integer("mesh.core_layers", core_layers, 1)
    grading = check_positive("mesh.grading", grading)
    if structured is None:
        structured = outline.is_convex_quadrilateral
    elif not isinstance(structured, bool):
        raise InputError("mesh.structured", f"must be True, False or None, got {structured!r}")
    elif structured and not outline.is_convex_quadrilateral:
        raise InputError(
            "mesh.structured", "a structured mesh needs a convex 4-corner polygon outline"
        )

    layers = [("skin_bottom", t, 1, [1.0])] * plies
    layers.append(("core", H, core_layers, _layer_heights(core_layers, grading)))
    layers += [("skin_top", t, 1, [1.0])] * plies
    z_core = plies * t
    ranges = [("skin_bottom", i * t, (i + 1) * t) for i in range(plies)]
    ranges.append(("core", z_core, z_core + H))
    ranges += [("skin_top", z_core + H + i * t, z_core + H + (i + 1) * t) for i in range(plies)]
    z = ranges[-1][2]

    import gmsh

    initialised = gmsh.isInitialized()
    if not initialised:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    options = dict(_OPTIONS, **{"Mesh.MeshSizeMax": h})
    saved = {k: gmsh.option.getNumber(k) for k in options}  # restored at the end
    for k, v in options.items():
        gmsh.option.setNumber(k, v)
    gmsh.model.add(name)
    try:
        # every rank raises a failure of the meshing rank (the others wait for its mesh)
        built = on_root(comm, lambda: _build(gmsh, outline, layers, h, structured),
                        gmsh_field="mesh.outline")
        facet_groups, unions = built if built is not None else ({}, {})
        facet_groups, unions = comm.bcast((facet_groups, unions), root=0)
        md = mesh_from_gmsh(gmsh, comm, partition)
    finally:
        gmsh.model.remove()
        for k, v in saved.items():
            gmsh.option.setNumber(k, v)
        if not initialised:
            gmsh.finalize()

    names = dict(md.names)
    union_tags = {u: tuple(facet_groups[a] for a in atoms) for u, atoms in unions.items()}
    for u, tags in union_tags.items():
        if len(tags) == 1:
            names[u] = (2, tags[0])
    result = SandwichMesh(md.mesh, md.cell_tags, md.facet_tags, names, union_tags,
                          tuple(ranges))
    counts = {b: result.owned_cell_count(b) for b in BODIES if b in names}
    if comm.rank == 0:
        log.info("sandwich blank %r: %s hexahedra, thickness %g mm", name,
                 ", ".join(f"{b} {n}" for b, n in counts.items()), z)
    return result
