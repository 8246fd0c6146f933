"""The implicit solver's Jacobian from compiled element matrices (``newton.jacobian``)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import block_scene, solver_taylor

from forming.contact.shapes import Plane
from forming.errors import InputError
from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.model import Model
from forming.scene import Body, Contact, Displacement, Linear, Scene, Tool, Traction
from forming.solver.implicit import ImplicitSolver
from forming.solver.options import NewtonOptions


def _sled_on_table(elasticity: str) -> Scene:
    """A crushable core block pressed onto a sliding table with friction (elastic slip)."""
    return Scene(
        "sled", box((100.0, 50.0, 20.0), (4, 2, 2)), (Body("core", honeycomb_core(elasticity)),),
        displacements=(Displacement("core", "top", x=0.0, y=0.0),),
        tractions=(Traction("core", "top", z=-0.002),),
        tools=(Tool("table", Plane((0, 0, 0), (0, 0, 1)), x=Linear(5.0)),),
        contacts=(Contact("core", "bottom", "table", friction=0.36, stick="elastic_slip"),))


def _plastic_state(model: Model, seed: int) -> np.ndarray:
    """Displacements that crush the block by 8% and shear it, with noise (every point
    yields), the prescribed values held."""
    x = model.body.V.tabulate_dof_coordinates()
    u = np.zeros((x.shape[0], 3))
    u[:, 2] = -0.08 * x[:, 2]  # compressive strain 0.08 (yield at 0.02)
    u[:, 0] = 0.02 * x[:, 2]
    return u.ravel() + np.random.default_rng(seed).normal(size=u.size) * 1e-3


def _jacobian(solver: ImplicitSolver, u: np.ndarray) -> np.ndarray:
    x = solver.unknowns()
    x.array[:] = u
    return solver.jacobian_at(x).convert("dense").getDenseArray().copy()


@pytest.mark.parametrize("scene", ["block", "sled"])
def test_compiled_jacobian_is_the_forms_jacobian(scene):
    """The compiled element matrices give DOLFINx's matrix of the forms, to 1e-12.

    At a plastic state (every point yields) of the transversely isotropic crushable
    core (an unsymmetric tangent), with prescribed rows and columns (a moving top face
    and fixed bottom; or a held top), and in the sled a frictional tool contact and a
    traction assembled from the forms on top. A failure means a term of the body's
    tangent is missing or mis-ordered, or the prescribed dofs are not treated as DOLFINx
    treats them (zero rows and columns, 1 on the diagonal).
    """
    spec = (block_scene(honeycomb_core("transverse"), clamped=True, cells=(2, 3, 2))
            if scene == "block" else _sled_on_table("transverse"))
    model = Model(spec)
    compiled = ImplicitSolver(model, NewtonOptions(jacobian="compiled"))
    forms = ImplicitSolver(model, NewtonOptions(jacobian="forms"))
    model.set_load(0.3)
    u = _plastic_state(model, seed=4)
    a_forms = _jacobian(forms, u)
    assert model.body.plastic.evp_trial.min() > 1e-3  # every point yields
    a_compiled = _jacobian(compiled, u)
    assert (compiled.jacobian_kind, forms.jacobian_kind) == ("compiled", "forms")
    scale = np.abs(a_forms).max()
    assert np.abs(a_compiled - a_forms).max() < 1e-12 * scale
    assert np.abs(a_forms - a_forms.T).max() > 1e-3 * scale  # the case is unsymmetric


def test_compiled_jacobian_taylor():
    """Slopes 1 and 2 of the Taylor remainders of the solver's own residual and compiled
    Jacobian, on the sliding sled at a crushed state. A slope of 1 for the second
    remainder means the compiled matrices are not the derivative of the residual."""
    model = Model(_sled_on_table("isotropic"))
    solver = ImplicitSolver(model, NewtonOptions(jacobian="compiled"))
    model.set_load(0.2)
    s1, s2 = solver_taylor(solver, model, seed=2, base=_plastic_state(model, seed=5))
    assert solver.jacobian_kind == "compiled"
    assert np.all(np.abs(s1 - 1.0) < 0.1), s1
    assert np.all(s2 > 1.9), s2


def test_unknown_or_impossible_jacobian_choice_is_an_input_error():
    """``newton.jacobian`` takes auto, compiled or forms; ``compiled`` needs P1
    hexahedra with 8 points (a degree-2 block has none) and says so."""
    with pytest.raises(InputError, match="newton.jacobian"):
        NewtonOptions(jacobian="fast")
    spec = block_scene(honeycomb_core("isotropic"), cells=(1, 1, 1))
    quadratic = Scene(spec.name, spec.mesh, (Body("core", honeycomb_core("isotropic"),
                                                  degree=2),), displacements=spec.displacements)
    model = Model(quadratic)
    with pytest.raises(InputError, match="newton.jacobian"):
        ImplicitSolver(model, NewtonOptions(jacobian="compiled"))
    assert ImplicitSolver(model, NewtonOptions()).jacobian_kind == "forms"  # auto
