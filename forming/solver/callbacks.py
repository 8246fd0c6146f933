"""Plumbing of the implicit solver's SNES callbacks (DOLFINx and PETSc)."""

from __future__ import annotations

import weakref

from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector, set_bc
from petsc4py import PETSc


def assemble_held_residual(x: PETSc.Vec, b: PETSc.Vec, residual, bcs,
                            _blocks=None, **_) -> None:
    """DOLFINx's ``assemble_residual`` at an ``x`` that holds every prescribed value.

    The Dirichlet lifting ``-J (g - x)`` is then exactly zero and is left out (it costs
    an assembly of the Jacobian over every cell with a prescribed dof); the rest is the
    same, so the vector is the same to the bit. ``x`` is already in the unknowns.
    """
    if _blocks is not None:
        b.setAttr("_blocks", _blocks)
        x.setAttr("_blocks", _blocks)
    with b.localForm() as local:
        local.set(0.0)
    assemble_vector(b, residual)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    if isinstance(residual, list | tuple):  # one form per body
        set_bc(b, fem.bcs_by_block(fem.extract_function_spaces(residual), bcs), x0=x,
               alpha=-1.0)
    else:
        set_bc(b, bcs, x0=x, alpha=-1.0)
    b.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)


def weak(method):
    """A function calling ``method`` through a weak reference to its object."""
    ref = weakref.WeakMethod(method)

    def call(*args):
        return ref()(*args)

    return call
