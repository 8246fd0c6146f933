"""Cost of assembling the core's Jacobian, against two other forms on the same mesh.

On a hexahedral box (default 20 x 20 x 4 cells, the `hemisphere` quarter mesh's size),
P1 vector displacement, 8 points per cell, the solve forms' JIT options, matrix pattern
known (every later Newton iteration's case), best of ``--repeats``:

- ``solid``: the core's Jacobian as `forming` writes it
  (:meth:`forming.bodies.solid.SolidBody.jacobian`: ``dF S + F (D : sym(F^T dF))`` in
  Mandel form, with a 6-vector stress and a 6 x 6 tangent at the points);
- ``dP/dF``: the same bilinear form with the first elasticity tensor ``A = dP/dF`` (81
  values per point, which a kernel would compute) as its only coefficient;
- ``vector Laplacian``: ``grad du : grad v``, the floor of matrix insertion and geometry.

Run: ``python benchmarks/jacobian_forms.py [--cells 20,20,4]`` (seconds; prints a table).
"""

from __future__ import annotations

import argparse
import time

import dolfinx_solver  # noqa: F401  (PETSc before dolfinx)

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import assemble_matrix, create_matrix
from mpi4py import MPI

from forming import compat
from forming.kinematics import mandel_contract, mandel_to_tensor, tensor_to_mandel


def forms(cells: tuple[int, int, int]) -> tuple[int, dict[str, ufl.Form]]:
    """The mesh's cell count and the three bilinear forms, with random coefficients."""
    msh = mesh.create_box(MPI.COMM_WORLD, [[0, 0, 0], [1, 1, 1]], list(cells),
                          mesh.CellType.hexahedron)
    V = fem.functionspace(msh, ("Lagrange", 1, (3,)))
    rng = np.random.default_rng(0)
    u = fem.Function(V)
    u.x.array[:] = 1e-3 * rng.random(u.x.array.size)

    def quadrature(shape: tuple[int, ...]) -> fem.Function:
        element = basix.ufl.quadrature_element(msh.basix_cell(), value_shape=shape, degree=2)
        f = fem.Function(fem.functionspace(msh, element))
        f.x.array[:] = rng.random(f.x.array.size)
        return f

    S, D, A = quadrature((6,)), quadrature((6, 6)), quadrature((9, 9))
    du, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.dx(metadata={"quadrature_degree": 2})
    F = ufl.Identity(3) + ufl.grad(u)
    dF = ufl.grad(du)
    dE = tensor_to_mandel(ufl.sym(F.T * dF))
    dP = dF * mandel_to_tensor(S) + F * mandel_to_tensor(mandel_contract(D, dE))
    i, J, k, L = ufl.indices(4)
    tensor = ufl.as_tensor([[[[A[3 * a + b, 3 * c + d] for d in range(3)] for c in range(3)]
                             for b in range(3)] for a in range(3)])
    dP_A = ufl.as_tensor(tensor[i, J, k, L] * dF[k, L], (i, J))
    n_cells = msh.topology.index_map(3).size_local
    return n_cells, {"solid": ufl.inner(dP, ufl.grad(v)) * dx,
                     "dP/dF": ufl.inner(dP_A, ufl.grad(v)) * dx,
                     "vector Laplacian": ufl.inner(dF, ufl.grad(v)) * dx}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", default="20,20,4")
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    cells = tuple(int(c) for c in args.cells.split(","))
    n_cells, bilinear = forms(cells)
    print(f"{n_cells} hexahedra ({args.cells}), best of {args.repeats}\n")
    print("| form | assembly [ms] | per cell [us] |\n|---|---:|---:|")
    for name, a in bilinear.items():
        form = fem.form(a, jit_options=compat.SOLVE_JIT_OPTIONS)
        M = create_matrix(form)
        best = np.inf
        for _ in range(args.repeats):
            M.zeroEntries()
            t0 = time.perf_counter()
            assemble_matrix(M, form)
            M.assemble()
            best = min(best, time.perf_counter() - t0)
        print(f"| {name} | {1e3 * best:.1f} | {1e6 * best / n_cells:.1f} |")


if __name__ == "__main__":
    main()
