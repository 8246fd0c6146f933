"""Quadrature-point values of a body as fields: the plastic strain, fracture energy."""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.bodies import SolidBody
from forming.parallel import assemble_scalar


def point_function(body: SolidBody, name: str) -> tuple[fem.Function, np.ndarray]:
    """A scalar function at the body's quadrature points.

    Returns:
        The function, and its entries at the owned points in
        :attr:`~SolidBody.point_cells` order.
    """
    import basix.ufl

    Q = fem.functionspace(body.mesh, basix.ufl.quadrature_element(
        body.mesh.basix_cell(), value_shape=(), degree=body.quadrature_degree))
    return fem.Function(Q, name=name), Q.dofmap.list[body.point_cells].ravel()


class PlasticStrainField:
    """The volumetric plastic strain as a quadrature function, with its integrals.

    Args:
        body: A plastic body (its ``plastic`` state is read at each :meth:`update`).
    """

    def __init__(self, body: SolidBody):
        if body.plastic is None:
            raise ValueError(f"body {body.name!r} has no plastic state")
        self.body = body
        self.evp, self._dofs = point_function(body, "evp")
        self._forms: dict[str, fem.Form] = {}

    def update(self) -> None:
        """Copy the converged plastic strain into the quadrature function."""
        self.evp.x.array[self._dofs] = self.body.plastic.evp

    def integral(self, integrand) -> float:
        """Integral of a UFL expression over the body (reference volume), all ranks.

        Compiled forms are kept by signature: vary a ``fem.Constant``, not a float, to
        reuse one.
        """
        ufl_form = integrand * self.body.own_dx
        key = ufl_form.signature()
        if key not in self._forms:
            self._forms[key] = fem.form(ufl_form)
        return assemble_scalar(self._forms[key])

    def crushed_volume(self, threshold: float = 0.01, where=None) -> float:
        """Reference volume where the volumetric plastic strain exceeds ``threshold``."""
        chi = ufl.conditional(ufl.gt(self.evp, threshold), 1.0, 0.0)
        return self.integral(chi if where is None else chi * where)

    def compaction_mean(self, where) -> float:
        """Volume average of the compaction ``max(evp, 0)`` over the indicator ``where``.

        Negative volumetric plastic strain is dilation, left out here.
        """
        return self.integral(ufl.max_value(self.evp, 0.0) * where) / self.integral(where)

    def mean(self, where) -> float:
        """Volume average of the plastic strain over the indicator ``where`` (UFL)."""
        vol = self.integral(where)
        return self.integral(self.evp * where) / vol if vol > 0 else 0.0


_FIELDS: dict[int, PlasticStrainField] = {}


def plastic_field(body: SolidBody) -> PlasticStrainField:
    """The body's plastic-strain field (built once per body), updated to its state."""
    field = _FIELDS.get(id(body))
    if field is None or field.body is not body:
        field = _FIELDS[id(body)] = PlasticStrainField(body)
    field.update()
    return field


class PointIntegral:
    """Integral over a body's reference volume of values given at its quadrature points.

    Args:
        body: A solid body (its :attr:`~SolidBody.point_cells` order the values).
    """

    def __init__(self, body: SolidBody):
        self.body = body
        self.values, self._dofs = point_function(body, "values")
        self._form = fem.form(self.values * body.own_dx)

    def __call__(self, values) -> float:
        """The integral of ``values`` (one per owned point), summed over all ranks."""
        self.values.x.array[self._dofs] = values
        return assemble_scalar(self._form)


_INTEGRALS: dict[int, PointIntegral] = {}


def fracture_energy(body: SolidBody) -> float:
    """Energy the body's fracture has dissipated [N mm] (0 unless it fractures; collective)."""
    dissipated = body.dissipated_density()
    if dissipated is None:
        return 0.0
    integral = _INTEGRALS.get(id(body))
    if integral is None or integral.body is not body:
        integral = _INTEGRALS[id(body)] = PointIntegral(body)
    return integral(dissipated)
