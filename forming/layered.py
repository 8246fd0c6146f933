"""Sandwich blanks from any outline with each body meshed on its own (finite sliding).

:func:`forming.sandwich.sandwich_blank` extrudes one conforming mesh whose bodies share
their interface nodes (small sliding). Here each body is extruded from its own
quadrilateral mesh of the outline: the core at ``element_size``, the skins at
``element_size / refinement`` (or any other size: the meshes need not match), so the
bodies share no nodes and a skin can slide on the core any distance
(:mod:`forming.contact.sliding`). The groups are named per body like
:func:`forming.mesh.blocks`: volumes ``skin_bottom``, ``core``, ``skin_top``; faces
``<body>_bottom``, ``<body>_top``, ``<body>_xmin`` and ``<body>_ymin`` (the lateral faces
on the outline's lowest x and y: symmetry planes of a quarter model) and
``<body>_edge`` (the other lateral faces: the blank's free edge).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from forming.errors import InputError
from forming.mesh import MeshData, mesh_from_gmsh
from forming.outline import Outline, check_integer, check_positive
from forming.parallel import on_root

_QUAD, _HEX = 3, 5  # gmsh element types
FACES = ("bottom", "top", "xmin", "ymin", "edge")


def quadrilaterals(gmsh, outline: Outline, size: float) -> tuple[np.ndarray, np.ndarray]:
    """All-quadrilateral mesh of the outline: nodes (n, 2) and counter-clockwise quads (m, 4).

    Raises:
        InputError: gmsh left triangles or inverted quadrilaterals.
    """
    from forming.sandwich import _OPTIONS

    for k, v in (_OPTIONS | {"Mesh.MeshSizeMax": size}).items():
        gmsh.option.setNumber(k, v)
    gmsh.model.add("outline")
    try:
        geo = gmsh.model.geo
        pts = [geo.addPoint(x, y, 0.0, size) for x, y in outline.points]
        if outline.kind == "spline":
            curves = [geo.addSpline(pts + [pts[0]])]
        else:
            curves = [geo.addSpline([pts[i % len(pts)] for i in range(a, b + 1)]) if b > a + 1
                      else geo.addLine(pts[a], pts[b % len(pts)])
                      for a, b in _runs(np.asarray(outline.points), size)]
        surface = geo.addPlaneSurface([geo.addCurveLoop(curves)])
        geo.synchronize()
        gmsh.model.mesh.setRecombine(2, surface)
        for algorithm in (3, 2):  # blossom full-quad, then simple full-quad
            gmsh.option.setNumber("Mesh.RecombinationAlgorithm", algorithm)
            gmsh.model.mesh.generate(2)
            types, _tags, nodes = gmsh.model.mesh.getElements(2, surface)
            if list(types) == [_QUAD]:
                break
            gmsh.model.mesh.clear()
        else:
            raise InputError("mesh.outline", f"gmsh left triangles in the in-plane mesh at "
                             f"element size {size:g}; try another size or a simpler outline")
        tags, coords, _ = gmsh.model.mesh.getNodes()
    finally:
        gmsh.model.remove()
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    xy = np.asarray(coords).reshape(-1, 3)[:, :2]
    quads = index[np.asarray(nodes[0], dtype=np.int64).reshape(-1, 4)]
    used, quads = np.unique(quads, return_inverse=True)
    xy, quads = xy[used], quads.reshape(-1, 4)
    p = xy[quads]
    area = 0.5 * np.sum(p[:, :, 0] * np.roll(p[:, :, 1], -1, axis=1)
                        - np.roll(p[:, :, 0], -1, axis=1) * p[:, :, 1], axis=1)
    quads[area < 0] = quads[area < 0][:, ::-1]
    # every corner of every quad must turn left (no inverted or degenerate corner)
    p = xy[quads]
    e1 = np.roll(p, -1, axis=1) - p
    e0 = p - np.roll(p, 1, axis=1)
    if np.any(e0[..., 0] * e1[..., 1] - e0[..., 1] * e1[..., 0] <= 0):
        raise InputError("mesh.outline", "gmsh produced inverted quadrilaterals")
    return xy, quads


def _runs(points: np.ndarray, size: float) -> list[tuple[int, int]]:
    """The outline's curves as (first, last) point indices (last may wrap past the end).

    Edges shorter than half the element size come in runs that become one spline through
    their points (a densely sampled curve, such as a developed blank), so the element
    size, not the sampling, sets the mesh; every other edge is a line.
    """
    n = len(points)
    short = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1) < 0.5 * size
    if short.all():
        return [(0, n)]  # one closed spline
    start = int(np.flatnonzero(~short)[0])  # begin after a long edge
    runs, i = [], start
    while i < start + n:
        j = i + 1
        while short[i % n] and j < start + n and short[j % n]:
            j += 1
        runs.append((i, j))
        i = j
    return runs


def _boundary_edges(quads: np.ndarray) -> np.ndarray:
    """Directed edges (k, 2) of the quad mesh used by one quad only (the outline)."""
    edges = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.sort(edges, axis=1)
    _u, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return edges[counts[inverse.reshape(-1)] == 1]


def _extrude(xy: np.ndarray, quads: np.ndarray, z: np.ndarray, bounds) -> dict:
    """Nodes, hexahedra and face quads of one body: the quad mesh through the levels z."""
    n, levels = len(xy), len(z)
    nodes = np.column_stack([np.tile(xy, (levels, 1)), np.repeat(z, n)])
    hexes = np.vstack([np.hstack([quads + k * n, quads + (k + 1) * n])
                       for k in range(levels - 1)])
    edges = _boundary_edges(quads)
    xmin, ymin, xmax, ymax = bounds
    tol = 1e-7 * max(xmax - xmin, ymax - ymin)
    on = {"xmin": np.all(np.abs(xy[edges, 0] - xmin) <= tol, axis=1),
          "ymin": np.all(np.abs(xy[edges, 1] - ymin) <= tol, axis=1)}
    on["edge"] = ~(on["xmin"] | on["ymin"])
    faces = {"bottom": quads, "top": quads + (levels - 1) * n}
    for name, which in on.items():
        e = edges[which]
        faces[name] = np.vstack([np.column_stack([e + k * n, e[:, ::-1] + (k + 1) * n])
                                 for k in range(levels - 1)]).reshape(-1, 4)
    return {"nodes": nodes, "hexes": hexes, "faces": faces}


def _levels(bottom: float, height: float, layers: int) -> np.ndarray:
    return bottom + height * np.linspace(0.0, 1.0, layers + 1)


def sliding_sandwich_mesh(outline: Outline, core_thickness: float = 20.0,
                          skin_thickness: float = 0.4, plies: int = 1,
                          element_size: float = 10.0, core_layers: int = 4,
                          refinement: int = 1, comm: MPI.Comm = MPI.COMM_WORLD) -> MeshData:
    """Hexahedral meshes of a core and its two skins, each on its own (see the module).

    z runs from 0: the bottom skin [0, plies t], the core [plies t, plies t + H], the
    top skin above; one element per ply.

    Args:
        outline: Blank outline in the x-y plane.
        core_thickness: Core thickness H [mm].
        skin_thickness: Ply thickness t [mm].
        plies: Plies per skin (>= 1).
        element_size: The core's in-plane element size [mm].
        core_layers: Elements through the core.
        refinement: Skin elements per core element along each in-plane direction.
        comm: Communicator (meshed on rank 0, then distributed).
    """
    if not isinstance(outline, Outline):
        raise InputError("mesh.outline", f"must be an Outline, got {type(outline).__name__}")
    H = check_positive("mesh.core_thickness", core_thickness)
    t = check_positive("mesh.skin_thickness", skin_thickness)
    plies = check_integer("mesh.plies", plies, 1)
    h = check_positive("mesh.element_size", element_size)
    core_layers = check_integer("mesh.core_layers", core_layers, 1)
    refinement = check_integer("skin_refinement", refinement, 1)
    xmin, ymin, xmax, ymax = outline.bounds
    if h > min(xmax - xmin, ymax - ymin):
        raise InputError("mesh.element_size", f"{h:g} is larger than the outline's smallest "
                         f"extent {min(xmax - xmin, ymax - ymin):g}")
    import gmsh

    started = gmsh.isInitialized()
    if not started:
        gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)

    def build() -> None:
        core2d = quadrilaterals(gmsh, outline, h)
        skin2d = core2d if refinement == 1 else quadrilaterals(gmsh, outline, h / refinement)
        bodies = {"skin_bottom": _extrude(*skin2d, _levels(0.0, plies * t, plies),
                                          outline.bounds),
                  "core": _extrude(*core2d, _levels(plies * t, H, core_layers),
                                   outline.bounds),
                  "skin_top": _extrude(*skin2d, _levels(plies * t + H, plies * t, plies),
                                       outline.bounds)}
        _discrete_model(gmsh, bodies)

    try:
        on_root(comm, build)
        return mesh_from_gmsh(gmsh, comm)
    finally:
        if comm.rank == 0 and "sliding_sandwich" in gmsh.model.list():
            gmsh.model.setCurrent("sliding_sandwich")
            gmsh.model.remove()
        if not started:
            gmsh.finalize()


def _discrete_model(gmsh, bodies: dict[str, dict]) -> None:
    """A gmsh model of discrete entities holding the bodies' nodes, cells and faces."""
    gmsh.model.add("sliding_sandwich")
    node0, element0, entity = 1, 1, 1
    for group, (name, body) in enumerate(bodies.items(), start=1):
        n = len(body["nodes"])
        gmsh.model.addDiscreteEntity(3, group)
        tags = np.arange(node0, node0 + n)
        gmsh.model.mesh.addNodes(3, group, tags, body["nodes"].ravel())
        hexes = body["hexes"] + node0
        gmsh.model.mesh.addElements(3, group, [_HEX], [np.arange(element0, element0
                                                                  + len(hexes))],
                                    [hexes.ravel()])
        element0 += len(hexes)
        gmsh.model.addPhysicalGroup(3, [group], group, name=name)
        for face in FACES:
            quads = body["faces"][face]
            if not len(quads):
                continue
            gmsh.model.addDiscreteEntity(2, entity)
            gmsh.model.mesh.addElements(2, entity, [_QUAD], [np.arange(element0, element0
                                                                       + len(quads))],
                                        [(quads + node0).ravel()])
            element0 += len(quads)
            gmsh.model.addPhysicalGroup(2, [entity], entity, name=f"{name}_{face}")
            entity += 1
        node0 += n
