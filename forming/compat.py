"""Everything that depends on how DOLFINx was installed or on its version.

The PyPI stack ships PETSc in ``dolfinx_solver``, which must be imported before
``dolfinx``; conda and Docker builds have no such module.
"""

from __future__ import annotations

import importlib.metadata
import os
import sys

try:  # PyPI wheels: load the PETSc that dolfinx was built against
    import dolfinx_solver  # noqa: F401
except ImportError:  # conda / Docker DOLFINx 0.11
    pass

import dolfinx  # noqa: E402
import dolfinx.fem.petsc  # noqa: E402,F401
import dolfinx.io  # noqa: E402
import numpy as np  # noqa: E402
import ufl  # noqa: E402
from petsc4py import PETSc  # noqa: E402
from ufl.algorithms import expand_derivatives  # noqa: E402
from ufl.corealg.map_dag import map_expr_dag  # noqa: E402
from ufl.corealg.multifunction import MultiFunction  # noqa: E402

# C compiler flags of the solve forms (residual and Jacobian): vectorised for the machine
# that runs them (the FFCx cache is per machine). DOLFINx's default is "-O2 -g0". "-g0"
# drops the debug information Python's own CFLAGS ask for ("-g"): the same code, compiled
# faster. FORMING_SOLVE_CFLAGS (space-separated) replaces them: the test suite
# compiles with "-O2" (benchmarks/jit_flags.py, docs/performance.md).
SOLVE_CFLAGS = ("-O3", "-march=native", "-g0")
SOLVE_JIT_OPTIONS = {"cffi_extra_compile_args":
                     os.environ.get("FORMING_SOLVE_CFLAGS", "").split() or list(SOLVE_CFLAGS)}


def _python_signal_handling() -> None:
    """Give signals back to Python.

    PETSc's handler (installed when PETSc starts) turns Ctrl-C into error 73 inside a
    solve and a closed pipe (``| head``) into an abort. Python's defaults come back:
    KeyboardInterrupt, SIGPIPE ignored; runs install their own stop handler
    (:mod:`forming.signals`).
    """
    import signal

    try:
        PETSc.Sys.popSignalHandler()
    except (PETSc.Error, AttributeError):
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGPIPE, signal.SIG_IGN)


try:
    _python_signal_handling()
except ValueError:  # imported outside the main thread: nothing to change
    pass

REQUIRED = (0, 11)
_ver = tuple(int(x) for x in dolfinx.__version__.split(".")[:2])
if _ver != REQUIRED:
    raise ImportError(
        f"forming needs DOLFINx {REQUIRED[0]}.{REQUIRED[1]}, found {dolfinx.__version__} "
        f"at {dolfinx.__file__}; run scripts/dev.sh to create the pinned environment"
    )


def model_to_mesh(model, comm, rank: int = 0, gdim: int = 3, partition: str = "graph"):
    """Convert a gmsh model into a DOLFINx mesh whose interior facets are ghosted.

    ``partition`` shares the cells among the ranks (:mod:`forming.partition`).
    Returns the ``MeshData`` of :func:`dolfinx.io.gmsh.model_to_mesh` (mesh, cell_tags,
    facet_tags, physical_groups, ...).
    """
    from forming import partition as part

    part.check(partition)
    if comm.size == 1:  # one rank holds every cell, whatever the partition
        partition = "graph"
    centroids = None
    if partition != "graph":
        centroids = _gmsh_cell_centres(model) if comm.rank == rank else np.zeros((0, 3))
    return dolfinx.io.gmsh.model_to_mesh(model, comm, rank, gdim=gdim,
                                         partitioner=part.cell_partitioner(partition, centroids))


def _gmsh_cell_centres(model) -> np.ndarray:
    """Centres of a gmsh model's cells in the order :func:`model_to_mesh` passes them on."""
    from forming.errors import InputError

    x = dolfinx.io.gmsh.extract_geometry(model)
    topologies, _groups = dolfinx.io.gmsh.extract_topology_and_markers(model)
    dims = {t: model.mesh.getElementProperties(t)[1] for t in topologies}
    tdim = max(dims.values())
    cells = [t for t, d in dims.items() if d == tdim]
    if len(cells) != 1:
        raise InputError("partition", f"a wedge partition needs one cell type, the mesh has "
                         f"{len(cells)}")
    topo = np.asarray(topologies[cells[0]]["topology"], dtype=np.int64)
    return x[topo].mean(axis=1)


def create_hex_mesh(comm, cells, x):
    """A hexahedral mesh from node coordinates and cells in gmsh's node order.

    Rank 0 passes the whole mesh and the other ranks empty arrays; interior facets are
    ghosted as in :func:`model_to_mesh`.
    """
    import basix.ufl
    import ufl

    from forming.partition import cell_partitioner

    perm = dolfinx.io.gmsh.cell_perm_array(dolfinx.mesh.CellType.hexahedron, 8)
    element = ufl.Mesh(basix.ufl.element("Lagrange", "hexahedron", 1, shape=(3,)))
    return dolfinx.mesh.create_mesh(comm, np.asarray(cells, dtype=np.int64)[:, perm], element,
                                    np.asarray(x, dtype=float), cell_partitioner("graph"))


def vtx_writer(comm, path, functions):
    """ParaView-readable ADIOS2 (BP4) writer for the given functions."""
    return dolfinx.io.VTXWriter(comm, str(path), functions, engine="BP4")


def versions() -> dict[str, str]:
    """Versions of the software a run depends on."""
    out = {"python": sys.version.split()[0], "dolfinx": dolfinx.__version__}
    out["petsc"] = ".".join(str(v) for v in PETSc.Sys.getVersion())
    for dist in ("fenics-ufl", "fenics-basix", "fenics-ffcx", "numba", "numpy", "mpi4py", "gmsh"):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            out[dist] = "not installed"
    try:
        out["forming"] = importlib.metadata.version("forming")
    except importlib.metadata.PackageNotFoundError:
        out["forming"] = "source tree"
    return out


def expression(expr, points: np.ndarray) -> dolfinx.fem.Expression:
    """A ``dolfinx.fem.Expression`` of ``expr`` at the reference ``points``, compiled once.

    FFCx 0.11 names an expression's module by a signature in which coefficients,
    constants and meshes are renumbered but the labels of ``ufl.variable`` are not: an
    expression that differentiates with respect to a variable (a contact gap's normal)
    got a new label, so a new module, every time a body was built, and the test suite
    compiled one expression up to 34 times (docs/performance.md, "Expressions compiled
    once"). The derivatives are applied and the variables replaced by what they stand for
    first: the same code, one signature.
    """
    nodes = ufl.corealg.traversal.unique_pre_traversal(expr)
    if any(isinstance(o, ufl.classes.Variable) for o in nodes):
        expr = map_expr_dag(_StripVariables(), expand_derivatives(expr))
    return dolfinx.fem.Expression(expr, points)


class _StripVariables(MultiFunction):
    """Each ``ufl.variable`` replaced by its expression; shared nodes visited once.

    UFL's own ``strip_variables`` visits a shared node once per path: 8 s for the 12
    expressions of ``tests/test_contact.py``'s square punch.
    """

    expr = MultiFunction.reuse_if_untouched

    def variable(self, o, expression, label):
        return expression
