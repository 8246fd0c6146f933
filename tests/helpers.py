"""Helpers shared by the test modules: Taylor tests, small scenes, run outputs, MPI.

Imported as ``from helpers import ...`` (pytest puts ``tests/`` on the path).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import dolfinx_solver  # noqa: F401  (PETSc and MPI before dolfinx)

import numpy as np
import ufl
from dolfinx import fem

import forming.compat  # noqa: F401
from forming.mesh import box
from forming.model import Model
from forming.scene import Body, Displacement, Linear, Scene

REPO = Path(__file__).resolve().parent.parent


def history(folder: Path) -> np.ndarray:
    """A run's ``history.csv`` as a structured array (columns by name)."""
    return np.genfromtxt(Path(folder) / "history.csv", delimiter=",", names=True)


# MPICH's ranks poll for messages without pause. Beside the other test worker, two ranks
# on two cores are three busy processes, and a rank waiting at a reduction takes the
# core its partner needs: these make a rank that polls 256 times for nothing sleep 1 us
# (on this suite's MPI tests: 26 -> 19 s for core_crushing 4,4,2 beside a busy core,
# 12.0 -> 11.0 s alone). Set in the environment, they are left as given.
MPI_THROTTLE = {"MPIR_CVAR_CH4_PROGRESS_THROTTLE": "1",
                "MPIR_CVAR_CH4_PROGRESS_THROTTLE_NO_PROGRESS_COUNT": "256"}


def run_mpi(args: list[str], n: int = 2, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run ``python args`` under ``mpirun -n n`` with the venv's MPI (killed at ``timeout``)."""
    mpirun = Path(sys.executable).parent / "mpirun"
    cmd = [str(mpirun), "-n", str(n), sys.executable, *args]
    env = dict(MPI_THROTTLE, **os.environ)
    env["OMP_NUM_THREADS"] = "1"
    return subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)


def run_python(args: list[str], timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``python args`` in the repository (killed at ``timeout``)."""
    return subprocess.run([sys.executable, *args], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout, check=False)


def taylor_slopes(residual: Callable[[np.ndarray], np.ndarray],
                  jacobian_action: np.ndarray, x0: np.ndarray, direction: np.ndarray,
                  eps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Slopes of the first and second Taylor remainders in log-log.

    ``|R(x0 + e d) - R(x0)|`` falls with slope 1, and ``|R(x0 + e d) - R(x0) - e J d|``
    with slope 2 when ``jacobian_action = J d`` is the derivative of ``R``.
    """
    r0 = residual(x0)
    e1, e2 = [], []
    for e in eps:
        r = residual(x0 + e * direction)
        e1.append(np.linalg.norm(r - r0))
        e2.append(np.linalg.norm(r - r0 - e * jacobian_action))
    logs = np.log(eps)
    return np.diff(np.log(e1)) / np.diff(logs), np.diff(np.log(e2)) / np.diff(logs)


def body_taylor(model: Model, u0: np.ndarray, seed: int = 0):
    """Taylor slopes of the first body's bulk residual and its Jacobian at ``u0``."""
    body = model.body
    v = ufl.TestFunction(body.V)
    du = ufl.TrialFunction(body.V)
    r_form = fem.form(body.residual(v))
    j_form = fem.form(body.jacobian(du, v))

    def residual(u):
        body.u.x.array[:] = u
        body.invalidate()
        body.update_material(want_tangent=True)
        return fem.assemble_vector(r_form).array.copy()

    residual(u0)
    jac = fem.assemble_matrix(j_form).to_dense()
    delta = np.random.default_rng(seed).normal(size=u0.size) * 1e-2
    eps = np.array([1e-1, 5e-2, 2.5e-2, 1.25e-2, 6.25e-3])
    return taylor_slopes(residual, jac @ delta, u0, delta, eps)


def block_offsets(model: Model) -> dict[str, int]:
    """Offset of every body's block in the implicit solver's unknowns (serial layout)."""
    offsets, o = {}, 0
    for name in model.names:
        offsets[name] = o
        o += model.bodies[name].V.dofmap.index_map.size_local * 3
    return offsets


def free_mask(model: Model, n: int) -> np.ndarray:
    """True on the unknowns without a prescribed displacement (``n`` unknowns)."""
    offsets = block_offsets(model)
    free = np.ones(n, dtype=bool)
    for bc, name in zip(model.dirichlet.bcs, model.dirichlet.bc_bodies, strict=True):
        idx, n_owned = bc.dof_indices()
        free[offsets[name] + np.asarray(idx)[:n_owned]] = False
    return free


def block_vector(model: Model, fields: dict[str, Callable[[np.ndarray], np.ndarray]]
                 ) -> np.ndarray:
    """Unknowns with the displacement ``fields[name](X)`` ((n, 3) at the reference
    coordinates X of body ``name``'s nodes) on the named bodies and zero elsewhere."""
    offsets = block_offsets(model)
    size = sum(b.V.dofmap.index_map.size_local * 3 for b in model.bodies.values())
    x = np.zeros(size)
    for name, field in fields.items():
        V = model.bodies[name].V
        n = V.dofmap.index_map.size_local
        X = V.tabulate_dof_coordinates()[:n]
        x[offsets[name]:offsets[name] + 3 * n] = np.asarray(field(X), dtype=float).ravel()
    return x


def solver_taylor(solver, model: Model, seed: int = 0, base: np.ndarray | None = None,
                  keep_prescribed: bool = False):
    """Taylor slopes of an implicit solver's own residual and Jacobian (all blocks).

    At ``base`` (default zero) plus random free displacements of 1e-3 mm; prescribed
    dofs stay at zero, where the lifted residual is the true residual, or with
    ``keep_prescribed`` at their values in ``base`` (which must then be the prescribed
    values of the current load). The model is left at that state, so a caller can read
    its outputs there.
    """
    x, b = solver.unknowns(), solver.unknowns()
    n = x.getLocalSize()
    free = free_mask(model, n)
    rng = np.random.default_rng(seed)
    x0 = rng.normal(size=n) * 1e-3
    if base is not None:
        x0 = x0 + base
    x0 = x0 * free + (base * (1 - free) if keep_prescribed else 0.0)

    def residual(xa):
        x.array[:] = xa
        solver.residual_at(x, b)
        return b.array.copy()

    residual(x0)
    x.array[:] = x0
    A = solver.jacobian_at(x)
    d = x.duplicate()
    d.array[:] = rng.normal(size=n) * 1e-3 * free
    jd = A.createVecLeft()
    A.mult(d, jd)
    slopes = taylor_slopes(residual, jd.array.copy(), x0, d.array.copy(),
                           np.array([4e-2, 2e-2, 1e-2, 5e-3]))
    residual(x0)
    return slopes


def block_taylor(model: Model, t: float, seed: int = 0, base: np.ndarray | None = None):
    """Taylor slopes of the implicit solver's block residual and Jacobian at load ``t``
    (see :func:`solver_taylor`)."""
    from forming.solver.implicit import ImplicitSolver
    from forming.solver.options import NewtonOptions

    solver = ImplicitSolver(model, NewtonOptions())
    model.set_load(t)
    return solver_taylor(solver, model, seed, base)


def block_scene(material, clamped: bool = False, cells=(2, 2, 2),
                stroke: float = -2.0) -> Scene:
    """A 10 mm cube on its bottom face, its top face pressed down by ``stroke`` [mm].

    Clamped: top and bottom also held in x and y; otherwise symmetry planes at x = 0 and
    y = 0 and free lateral faces (uniaxial stress).
    """
    lateral = {"x": 0.0, "y": 0.0} if clamped else {}
    return Scene(
        name="block", mesh=box((10.0, 10.0, 10.0), cells), bodies=(Body("core", material),),
        displacements=(
            Displacement("core", "bottom", z=0.0, reaction=False, **lateral),
            Displacement("core", "top", z=Linear(stroke), **lateral),
        ) + (() if clamped else (
            Displacement("core", "xmin", x=0.0, reaction=False),
            Displacement("core", "ymin", y=0.0, reaction=False))),
    )


def punch_footprint_area(stroke: float, half: float = 40.0, fillet: float = 20.0) -> float:
    """Plan area [mm^2] of a core's top face that a square punch with filleted edges has
    reached after ``stroke`` [mm] (the whole punch, not a quarter).

    The punch (``RoundedBox``) is its flat square of side ``2 (half - fillet)`` grown by
    a quarter-round of radius ``fillet``; the fillet dips to the core's face within
    ``w = sqrt(fillet^2 - (fillet - stroke)^2)`` of the flat, so the footprint is the
    flat square grown by ``w``: ``flat^2 + 4 flat w + pi w^2``.
    """
    d = min(max(stroke, 0.0), fillet)
    w = np.sqrt(fillet**2 - (fillet - d) ** 2)
    flat = 2.0 * (half - fillet)
    return flat**2 + 4.0 * flat * w + np.pi * w**2


def punch_footprint_force(strain: np.ndarray, stress: np.ndarray, stroke: float,
                          thickness: float = 20.0, half: float = 40.0, fillet: float = 20.0,
                          n: int = 400) -> float:
    """Punch force [N] of a core crushed as independent columns (the whole punch).

    Each column under the punch is compressed to the nominal strain ``depth /
    thickness``, the depth being the stroke less the fillet's height above the flat
    there, and carries the nominal stress of the uniaxial curve (``strain``,
    ``stress``) at that strain. This is the core's own response for a column that
    neither spreads (zero Poisson ratios) nor drags its neighbours (in-plane modulus
    0.2 MPa against 15 MPa through the thickness); it leaves out the transverse shear
    of the core at the footprint's edge and friction. Midpoint rule on an ``n x n``
    grid over a quarter of the punch.
    """
    flat = half - fillet
    x = (np.arange(n) + 0.5) / n * half
    gx, gy = np.meshgrid(x, x)
    rho = np.hypot(np.maximum(gx - flat, 0.0), np.maximum(gy - flat, 0.0))
    rise = np.where(rho < fillet, fillet - np.sqrt(np.maximum(fillet**2 - rho**2, 0.0)),
                    np.inf)
    depth = stroke - rise
    nominal = np.interp(np.clip(depth / thickness, 0.0, None), strain, stress)
    return float(4.0 * np.sum(np.where(depth > 0.0, nominal, 0.0)) * (half / n) ** 2)
