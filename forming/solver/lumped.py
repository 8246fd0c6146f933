"""What the explicit solver keeps per body: lumped mass, velocity and force vectors.

Row-sum lumping of a linear element's mass, the vectors of one body's internal and
external forces, and the contact and interface tractions assembled on their own (for
the energy ledger and the tool forces).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, la  # noqa: I001

from forming import compat  # noqa: F401
from forming.errors import InputError


def body_density(body) -> float:
    """Mass density of a model body [t/mm^3]: the scene body's, else its material's.

    Raises:
        InputError: Neither gives one.
    """
    rho = body.spec.density if body.spec.density is not None else getattr(
        body.material, "density", None)
    if rho is None:
        raise InputError(f"body.{body.spec.name}.density",
                         "the explicit solver needs a mass density (Body.density or the "
                         "material's density) [t/mm^3]")
    return float(rho)


class BodyState:
    """Velocity, acceleration, lumped mass and force vectors of one body."""

    def __init__(self, name: str, body, bcs: list[fem.DirichletBC]):
        self.name = name
        self.body = body
        V = body.V
        if body.spec.degree != 1:
            raise InputError(f"body.{name}.degree",
                             "the explicit solver needs linear elements (row-sum lumping)")
        self.n_owned = V.dofmap.index_map.size_local * 3
        self.bcs = bcs
        mask = np.zeros(body.u.x.array.size, dtype=bool)
        for bc in bcs:
            mask[bc.dof_indices()[0]] = True
        self.fixed = mask
        self.v = np.zeros_like(body.u.x.array)  # velocity at the half step
        self.a = np.zeros_like(self.v)
        self.f_int = fem.Function(V)  # internal forces (assembled, ghosts updated)
        self.f_all = fem.Function(V)  # full residual: internal minus external forces
        rho = body_density(body)
        w = ufl.TestFunction(V)
        mass = body.domain.form(rho * ufl.dot(ufl.as_vector([1.0, 1.0, 1.0]), w) * body.dx)
        self.m_phys = assembled(mass)
        if np.any(self.m_phys[: self.n_owned] <= 0):
            raise InputError(f"body.{name}", "a node has no mass (empty lumped row)")
        self.m = self.m_phys.copy()


def assembled(form: fem.Form, out: fem.Function | None = None) -> np.ndarray:
    """Assemble a vector form, sum shared entries and update ghosts."""
    vec = out.x if out is not None else la.vector(form.function_spaces[0].dofmap.index_map,
                                                   form.function_spaces[0].dofmap.index_map_bs)
    vec.array[:] = 0.0
    fem.assemble_vector(vec.array, form)
    vec.scatter_reverse(la.InsertMode.add)
    vec.scatter_forward()
    return vec.array if out is not None else vec.array.copy()


class ExternalTerm:
    """A contact or interface traction on one body, assembled alone (energy bookkeeping)."""

    def __init__(self, state: BodyState, form: fem.Form, contact=None):
        self.state = state
        self.form = form
        self.contact = contact  # the tool contact (a ContactTerm), None otherwise
        self.vec = fem.Function(state.body.V)
        self.r_old = np.zeros(state.n_owned)

    def update(self) -> None:
        """Keep the last residual, assemble the new one."""
        self.r_old[:] = self.vec.x.array[: self.state.n_owned]
        assembled(self.form, self.vec)

    @property
    def r_new(self) -> np.ndarray:
        """The term's owned entries as last assembled."""
        return self.vec.x.array[: self.state.n_owned]
