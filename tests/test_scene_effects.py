"""The model builds only what the scene calls for."""

from __future__ import annotations

import textwrap

import ufl
from helpers import run_python

from forming.materials.library import honeycomb_core
from forming.mesh import box
from forming.model import Model
from forming.scene import Body, Displacement, Linear, Scene


def _scene(material) -> Scene:
    return Scene(
        name="s", mesh=box((10.0, 10.0, 10.0), (1, 1, 1)), bodies=(Body("core", material),),
        displacements=(Displacement("core", "bottom", x=0.0, y=0.0, z=0.0, reaction=False),
                       Displacement("core", "top", z=Linear(-1.0))),
    )


def _coefficient_names(form) -> set[str]:
    return {c.name for c in ufl.algorithms.extract_coefficients(form)}


def test_elastic_body_allocates_no_plastic_state():
    model = Model(_scene(honeycomb_core(plastic=False)))
    body = model.body
    assert body.plastic is None
    assert not body.material.kernel_data().plastic
    v = ufl.TestFunction(body.V)
    # the residual holds the displacement and the quadrature stress, nothing else
    assert _coefficient_names(body.residual(v)) == {"u", "S"}
    assert _coefficient_names(body.jacobian(ufl.TrialFunction(body.V), v)) == {"u", "S", "D"}


def test_plastic_body_allocates_history_per_quadrature_point():
    model = Model(_scene(honeycomb_core(plastic=True)))
    body = model.body
    assert body.plastic is not None
    assert body.plastic.ep.shape == (body.n_points, 6)
    assert body.plastic.evp.shape == (body.n_points,)
    assert body.n_points == 8  # one hexahedron, degree-2 Gauss rule


def test_displacement_only_scene_has_only_bulk_integrals():
    """No traction, contact or body-force terms when the scene has none."""
    body = Model(_scene(honeycomb_core())).body
    form = body.residual(ufl.TestFunction(body.V))
    assert {itg.integral_type() for itg in form.integrals()} == {"cell"}


def test_elastic_scene_never_compiles_the_return_mapping():
    """numba compiles per function: an elastic run leaves the foam kernel uncompiled."""
    code = textwrap.dedent("""
        import forming.compat
        from forming.materials import kernels
        from forming.materials.library import honeycomb_core
        from forming.mesh import box
        from forming.model import Model
        from forming.scene import Body, Scene
        Model(Scene("s", box((1.0, 1.0, 1.0), (1, 1, 1)),
                    (Body("core", honeycomb_core(plastic=False)),)))
        print(len(kernels.elastic_points.signatures), len(kernels.foam_points.signatures))
    """)
    proc = run_python(["-c", code], timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["1", "0"]
