"""Adaptive integration of a crushable core in the explicit solver.

The adaptive loops must be exactly the two integrations they combine (thickness
integration while no element has moved, full integration where one has), move the
elements that crush unevenly and no other, and survive a restart.
"""

from __future__ import annotations

import numpy as np
from dolfinx import la
from helpers import REPO  # noqa: F401  (PETSc before dolfinx)
from test_hexforce import DENSITY, _assert_equals_the_form, _body

from forming.bodies.hexadaptive import AdaptiveHexForce
from forming.bodies.hexforce import HexInternalForce
from forming.errors import InputError
from forming.materials.library import honeycomb_core


def _forces(body, loop, u):
    out = la.vector(body.V.dofmap.index_map, 3)
    body.u.x.array[:] = u
    loop.forces(out)
    return out.array.copy()


def _foam_body(**kw):
    return _body(honeycomb_core("isotropic", plastic=True), **kw)


def test_adaptive_loops_are_the_two_integrations_they_combine():
    """Before any move: thickness integration; every element moved: full integration.

    On a distorted mesh at a random displacement the adaptive loops' forces equal a
    thickness-integrated loop's to 1e-12 of the largest force before any element has
    moved, and the implicit solver's residual form (full integration) to 1e-10 once every
    element has. A failure means the two loops take other elements, gradients or
    history than the integrations they stand for.
    """
    body = _foam_body(distort=0.2)
    rng = np.random.default_rng(3)
    u = 0.3 * rng.uniform(-1, 1, body.u.x.array.size)
    adaptive = AdaptiveHexForce(body, "thickness", 0.1, DENSITY)
    thickness = HexInternalForce(body, "thickness", 0.1, DENSITY)
    f_a, f_t = _forces(body, adaptive, u), _forces(body, thickness, u)
    assert np.max(np.abs(f_a - f_t)) <= 1e-12 * np.max(np.abs(f_t))
    adaptive.move_to_full(np.arange(adaptive.n_cells))
    assert adaptive.full_fraction == 1.0
    _assert_equals_the_form(body, _forces(body, adaptive, u))


def test_an_even_compression_moves_no_element_and_a_bend_does():
    """The trigger: corners compressed unevenly, not compression as such.

    A uniform 3% compression through the thickness (six times the 0.5% threshold; every
    corner the same volume ratio) moves no element: the one point represents it exactly.
    A bend of the block about its width (the top fibres shortened by 3%, the bottom
    stretched by as much) moves the elements of the top layer, whose corners now differ
    and are compressed, and none of the bottom layer, which is only stretched. A
    failure means the check moves elements that the one point represents, or keeps
    those it misses.
    """
    body = _foam_body(size=(30.0, 20.0, 10.0), cells=(3, 2, 2))
    x = body.V.tabulate_dof_coordinates()
    loop = AdaptiveHexForce(body, "thickness", 0.1, DENSITY, strain=0.005, check_every=1)
    even = np.zeros_like(x)
    even[:, 2] = -0.03 * x[:, 2]
    _forces(body, loop, even.ravel())
    loop.commit()
    assert loop.full_fraction == 0.0
    bend = np.zeros_like(x)
    bend[:, 0] = -0.06 * (x[:, 0] - 15.0) * (x[:, 2] - 5.0) / 10.0
    _forces(body, loop, bend.ravel())
    loop.commit()
    centres = x[body.V.dofmap.list[body.point_cells]].mean(axis=1)
    assert np.array_equal(loop.full, centres[:, 2] > 5.0)


def test_the_adaptive_state_survives_a_restart():
    """Which elements are fully integrated, their plastic history and the hourglass work.

    Some elements moved after a crushing displacement; a new set of loops given the
    first's state (and the body's plastic state, as a restart restores it) has the same
    elements moved, the same hourglass energy and the same forces at a new displacement
    to 1e-12. A failure means a restarted adaptive run would depart from the
    uninterrupted one.
    """
    body = _foam_body(cells=(4, 2, 2))
    x = body.V.tabulate_dof_coordinates()
    loop = AdaptiveHexForce(body, "thickness", 0.1, DENSITY, check_every=1)
    u = np.zeros_like(x)  # a punch on one end: crushing under it, a gradient at its edge
    u[:, 2] = -0.08 * np.clip(15.0 - x[:, 0], 0.0, None) / 15.0 * x[:, 2]
    _forces(body, loop, u.ravel())
    loop.commit()
    assert 0.0 < loop.full_fraction < 1.0
    loop.push()
    again = AdaptiveHexForce(body, "thickness", 0.1, DENSITY, check_every=1)
    again.pull()
    again.set_state(loop.state())
    assert np.array_equal(again.full, loop.full)
    assert abs(again.hourglass_energy - loop.hourglass_energy) <= 1e-12 * max(
        loop.hourglass_energy, 1e-30)
    u2 = 1.1 * u.ravel()
    f1, f2 = _forces(body, loop, u2), _forces(body, again, u2)
    assert np.max(np.abs(f1 - f2)) <= 1e-12 * np.max(np.abs(f1))


def test_bad_adaptive_settings_name_the_field():
    """An unknown base or a threshold outside (0, 1) is refused with the option's name."""
    body = _foam_body()
    for kwargs, field in (({"base": "full"}, "explicit.integration"),
                          ({"strain": 0.0}, "explicit.adaptive_strain")):
        args = {"base": "thickness", "strain": 0.005} | kwargs
        try:
            AdaptiveHexForce(body, args["base"], 0.1, DENSITY, strain=args["strain"])
        except InputError as err:
            assert field in str(err)
        else:
            raise AssertionError(f"{kwargs} accepted")
