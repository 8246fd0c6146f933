"""Compile the numba kernels once, before the runs or tests that need them.

numba compiles a kernel at its first call and keeps the machine code on disk
(``NUMBA_CACHE_DIR``). Processes that start on a cold cache each compile what they
need, side by side: both ranks of an ``mpirun -n 2`` run, or both workers of the test
suite, compile the same kernels at once (the material kernels alone take about half a
minute of a core). ``forming warmup`` compiles them once, through small models of the
public API, so that every kernel is compiled for the argument types the runs pass. Its
three parts are independent: ``--part materials`` (the point kernels of every solid
material), ``--part solvers`` (a block under a plate, implicit and explicit, fully and
reduced-integrated, and a fracturing block) and ``--part contact`` (a fabric sliding on a
block, finite sliding with a stabilising spring, under a tool given as a surface mesh,
implicit and explicit), so the cores can share the work. Kernels it does not reach
(self-contact) still compile at their first call.
"""

from __future__ import annotations

import logging
import tempfile
import time
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

PARTS = ("materials", "solvers", "contact")


def materials() -> None:
    """Every solid material's point kernel, with each tangent, frozen, and without."""
    from forming.materials import ElasticSolid, IsotropicElasticity
    from forming.materials.fracture import FracturingSolid
    from forming.materials.library import honeycomb_core
    from forming.materials.solids import evaluate

    rng = np.random.default_rng(0)
    f = np.eye(3) + 0.05 * rng.normal(size=(4, 3, 3))
    cmats = np.einsum("nki,nkj->nij", f, f).reshape(-1, 9)
    foams = [honeycomb_core(kind) for kind in ("isotropic", "transverse")]
    solids = [*foams, *(honeycomb_core(kind, plastic=False)
                        for kind in ("isotropic", "transverse")),
              ElasticSolid(IsotropicElasticity(100.0, 0.3)),
              FracturingSolid(IsotropicElasticity(410.0, 0.21), erosion=True)]
    hist = np.zeros((len(cmats), 6)), np.zeros(len(cmats))
    for solid in solids:
        for tangent in ("closed", "difference"):
            evaluate(solid, cmats, *hist, tangent=tangent)
        evaluate(solid, cmats, *hist, want_tangent=False)
    for foam in foams:  # elastic about the plastic state (the explicit time step)
        evaluate(foam, cmats, *hist, frozen=True)


def solvers(folder: Path) -> None:
    """A core block under a plate, implicit and explicit, and a fracturing block.

    The explicit core runs with full and with reduced integration; the fracturing
    block is quadratic (its forces through the forms). Outputs go into ``folder``.
    """
    from forming.contact.shapes import Plane
    from forming.job import Job
    from forming.materials import IsotropicElasticity
    from forming.materials.fracture import FracturingSolid
    from forming.materials.library import honeycomb_core
    from forming.mesh import box
    from forming.run import simulate
    from forming.scene import Body, Contact, Displacement, Linear, Scene, Tool
    from forming.solver.options import ExplicitOptions
    from forming.solver.stepping import StepControl

    def scene(material, degree: int) -> Scene:
        return Scene("warmup", box((2.0, 2.0, 1.0), (1, 1, 1)),
                     (Body("block", material, degree=degree),),
                     displacements=(Displacement("block", "bottom", x=0.0, y=0.0, z=0.0),),
                     tools=(Tool("plate", Plane((0.0, 0.0, 1.0), (0.0, 0.0, -1.0)),
                                 z=Linear(-0.05)),),
                     contacts=(Contact("block", "top", "plate", friction=0.2),))

    core = honeycomb_core("isotropic")
    steps = StepControl(initial=0.5, max=0.5, min=0.5)
    runs = [("implicit", core, 1, "full"), ("explicit", core, 1, "full"),
            ("explicit", core, 1, "reduced"),
            ("explicit", FracturingSolid(IsotropicElasticity(410.0, 0.21), erosion=True,
                                         density=7.4e-10), 2, "full")]
    for k, (solver, material, degree, integration) in enumerate(runs):
        job = Job(scene(material, degree), steps=steps, solver=solver,
                  explicit=ExplicitOptions(loading_time=2e-5, integration=integration))
        simulate(job, folder / str(k), "warmup", {})


def contact(folder: Path) -> None:
    """A fabric sliding on a block under a sheet given as an STL file.

    Finite sliding (area transfer, a stabilising spring) and a surface-mesh tool with the
    elastic-slip stick law; implicit, then explicit. Outputs go into ``folder``.
    """
    import meshio

    from forming.contact.surface import SurfaceTool
    from forming.job import Job
    from forming.materials.fabric import NonCrimpFabric
    from forming.materials.library import honeycomb_core
    from forming.mesh import Block, blocks
    from forming.run import simulate
    from forming.scene import Body, Contact, Displacement, Linear, Scene, Sliding, Tool
    from forming.solver.options import ExplicitOptions
    from forming.solver.stepping import StepControl

    sheet = folder / "sheet.stl"
    meshio.write(sheet, meshio.Mesh(np.array([[-10.0, -10.0, 0.0], [30.0, -10.0, 0.0],
                                              [30.0, 30.0, 0.0], [-10.0, 30.0, 0.0]]),
                                    [("triangle", np.array([[0, 2, 1], [0, 3, 2]]))]), binary=True)
    mesh = blocks([Block("core", (20.0, 20.0, 4.0), (2, 2, 1)),
                   Block("skin", (10.0, 10.0, 0.4), (3, 3, 1), origin=(5.0, 5.0, 4.0))])
    tool = SurfaceTool(sheet, sheet=True, translate=(0.0, 0.0, 4.4))
    scene = Scene("warmup", mesh, (Body("core", honeycomb_core(), region="core"),
                                   Body("skin", NonCrimpFabric(thickness=0.4), region="skin")),
                  displacements=(Displacement("core", "core_bottom", x=0.0, y=0.0, z=0.0),),
                  tools=(Tool("press", tool, z=Linear(-0.02)),),
                  contacts=(Contact("skin", "skin_top", "press", friction=0.2,
                                    stick="elastic_slip"),),
                  sliding=(Sliding("skin", "core", "core_top", "skin", "skin_bottom",
                                   friction=0.5, stabilisation=1e-3),))
    steps = StepControl(initial=0.5, max=0.5, min=0.5)
    for k, solver in enumerate(("implicit", "explicit")):
        job = Job(scene, steps=steps, solver=solver, explicit=ExplicitOptions(loading_time=2e-5))
        simulate(job, folder / str(k), "warmup", {})


def main(part: str | None = None) -> int:
    """Compile the kernels of ``part`` (None: every part, one after the other).

    The small models' progress and warnings are not logged, only what each part took.
    """
    package = logging.getLogger("forming")
    levels = package.level, log.level
    package.setLevel(logging.ERROR)  # (the small models are not quasi-static: no warnings)
    log.setLevel(logging.INFO)
    try:
        for name in PARTS if part is None else (part,):
            t0 = time.perf_counter()
            if name == "materials":
                materials()
            else:
                with tempfile.TemporaryDirectory() as tmp:
                    (solvers if name == "solvers" else contact)(Path(tmp))
            log.info("warmup: %s kernels ready in %.1f s", name, time.perf_counter() - t0)
    finally:
        package.setLevel(levels[0])
        log.setLevel(levels[1])
    return 0
