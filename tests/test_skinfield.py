"""Comparing skin shear fields of different models material point by material point.

The fidelity ladder (benchmarks/fidelity_ladder.py) measures a drape's and a coarser run's
shear against the finest run's by interpolating them onto its cell centres; these tests
check that the interpolation and the material addressing are exact where they must be.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from forming.output import hex_volumes
from forming.post.skinfield import CellField, DrapeField, bilinear, rms


def _grid_field(n=(6, 4), h=(25.0, 37.5), f=lambda x, y: 2.0 * x - 0.5 * y + 3.0):
    xs = (np.arange(n[0]) + 0.5) * h[0]
    ys = (np.arange(n[1]) + 0.5) * h[1]
    X, Y = (a.ravel() for a in np.meshgrid(xs, ys, indexing="ij"))
    P = np.column_stack([X, Y, np.full(X.size, 20.2)])
    rng = np.random.default_rng(1)
    order = rng.permutation(X.size)  # the file's order is not the grid's
    P = P[order]
    return CellField(P, P, np.full(X.size, h[0] * h[1] * 0.4), f(P[:, 0], P[:, 1])), f


def test_bilinear_reproduces_bilinear_functions():
    """Bilinear interpolation is exact for a + b x + c y + d x y; NaN outside the grid
    and next to a NaN node. A failure means the fields of the ladder are misplaced."""
    i, j = np.meshgrid(np.arange(5.0), np.arange(3.0), indexing="ij")
    values = 1.0 + 2.0 * i - 3.0 * j + 0.5 * i * j
    a, b = np.array([0.0, 3.7, 4.0, 1.25, -0.1]), np.array([0.0, 1.2, 2.0, 0.5, 1.0])
    out = bilinear(values, a, b)
    np.testing.assert_allclose(out[:4], 1 + 2 * a[:4] - 3 * b[:4] + 0.5 * a[:4] * b[:4],
                               rtol=0, atol=1e-12)
    assert np.isnan(out[4])
    values[2, 1] = np.nan
    assert np.isnan(bilinear(values, np.array([1.5]), np.array([0.5])))[0]


def test_cell_field_interpolates_between_centres_and_clamps_at_the_edge():
    """A linear field given at shuffled cell centres is recovered exactly between them,
    held at the outer centres' values up to the edge and NaN beyond half a cell."""
    field, f = _grid_field()
    pts = np.array([[40.0, 30.0], [130.1, 120.0], [5.0, 60.0], [160.0, 60.0]])
    out = field.at(pts)
    np.testing.assert_allclose(out[:2], f(pts[:2, 0], pts[:2, 1]), atol=1e-10)
    assert out[2] == pytest.approx(f(12.5, 60.0))  # clamped to the first centre in x
    assert np.isnan(out[3])  # beyond the edge (150 mm)


def test_cell_field_on_scattered_centres_is_linear_exact_and_stops_a_cell_out():
    """Centres off a regular grid (a graded or unstructured skin mesh, the demonstrator's)
    are interpolated linearly over their triangles: a linear field is recovered exactly
    inside them; just outside, the nearest centre's value; a cell spacing beyond, NaN.
    A failure means the demonstrator's fidelity ladder compares misplaced values."""
    field, f = _grid_field()
    X = field.X.copy()
    X[:, 0] = X[:, 0] ** 1.2  # graded in x
    graded = CellField(X, X, field.volume, f(X[:, 0], X[:, 1]))
    pts = np.array([[60.0, 40.0], [150.0, 100.0], [X[:, 0].max() + 5.0, 60.0],
                    [X[:, 0].max() + 80.0, 60.0]])
    out = graded.at(pts)
    np.testing.assert_allclose(out[:2], f(pts[:2, 0], pts[:2, 1]), atol=1e-9)
    right = X[:, 0] == X[:, 0].max()
    nearest = np.argmin(np.abs(X[right, 1] - 60.0))
    assert out[2] == pytest.approx(graded.values[right][nearest])
    assert np.isnan(out[3])


def test_drape_field_addresses_nodes_by_their_flat_positions():
    """Node (i, j) of a net centred on the blank's point c (its origin cell's centre) is
    the material point c + d ((i - o_i - 1/2) e1 + (j - o_j - 1/2) e2): looked up there
    it returns that node's shear exactly, and NaN off the net."""
    rng = np.random.default_rng(3)
    shear = rng.normal(size=(9, 9))
    d, angle, origin, c = 7.5, -45.0, (4, 4), (10.0, -3.0)
    field = DrapeField(shear, c, d, angle, origin)
    a = math.radians(angle)
    e1, e2 = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    i, j = np.array([0, 4, 8, 2]), np.array([0, 5, 8, 7])
    pts = np.asarray(c) + d * ((i - origin[0] - 0.5)[:, None] * e1
                               + (j - origin[1] - 0.5)[:, None] * e2)
    np.testing.assert_allclose(field.at(pts), shear[i, j], atol=1e-12)
    assert np.isnan(field.at(np.array([[c[0] + 100.0, c[1]]])))[0]


def test_hex_volumes_exact_for_parallelepipeds():
    """The centre-Jacobian volume is exact for a sheared, stretched box (DOLFINx corner
    order); the skin fields are weighted with it."""
    k = np.arange(8)
    unit = np.column_stack([k & 1, k >> 1 & 1, k >> 2 & 1]).astype(float)
    A = np.array([[3.0, 0.5, 0.0], [0.2, 2.0, 0.1], [0.0, 0.3, 0.4]])
    corners = (unit @ A.T + [1.0, -2.0, 5.0])[None]
    assert hex_volumes(corners)[0] == pytest.approx(abs(np.linalg.det(A)), rel=1e-12)


def test_rms_weights_and_reports_cover():
    """Weighted RMS over the finite entries, with the weight fraction they cover."""
    value, cover = rms(np.array([3.0, np.nan, 4.0]), np.array([1.0, 2.0, 1.0]))
    assert value == pytest.approx(math.sqrt(12.5)) and cover == pytest.approx(0.5)
