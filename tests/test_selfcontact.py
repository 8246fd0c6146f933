"""Self-contact of a body's surface (folding cell walls, issue 20): two blocks of one body.

One body made of two blocks, a gap ``g`` apart; the upper one is pushed down onto the
lower one. The blocks share no cell, so the only thing between them is the self-contact.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from helpers import run_mpi

from forming.contact.selflist import VerletList, _excluded, candidates, distance2
from forming.errors import InputError
from forming.job import Job
from forming.materials import ElasticSolid, IsotropicElasticity
from forming.mesh import Block, MeshData, blocks
from forming.run import simulate
from forming.scene import Body, Displacement, Linear, Scene, SelfContact
from forming.solver.options import ExplicitOptions
from forming.solver.stepping import StepControl

E, RHO = 100.0, 1e-9  # MPa, t/mm^3
SIDE, HEIGHT, GAP, PUSH = 2.0, 2.0, 0.05, 0.1  # mm (strains below 1%: linear)


def _two_blocks(degree_cells: int = 2, gap: float = GAP) -> MeshData:
    """Two 2 x 2 x 2 mm blocks, one above the other, ``gap`` apart (negative: they
    overlap); the faces that meet form the group ``touching``."""
    from dolfinx import mesh as dmesh  # after forming (run as a script under mpirun)

    n = (degree_cells,) * 3
    md = blocks([Block("lower", (SIDE, SIDE, HEIGHT), n),
                 Block("upper", (SIDE, SIDE, HEIGHT), n, origin=(0.0, 0.0, HEIGHT + gap))])
    tags = md.facet_tags
    values = tags.values.copy()
    for name in ("lower_top", "upper_bottom"):
        values[np.isin(tags.indices, md.facets(name))] = 99
    facet_tags = dmesh.meshtags(md.mesh, 2, tags.indices, values)
    return MeshData(md.mesh, md.cell_tags, facet_tags, md.names | {"touching": (2, 99)})


def _scene(md: MeshData, degree: int = 1, **self_contact) -> Scene:
    solid = ElasticSolid(IsotropicElasticity(E=E, nu=0.0), density=RHO)
    return Scene("blocks", md, (Body("blocks", solid, degree=degree),), displacements=(
        Displacement("blocks", "lower_bottom", x=0.0, y=0.0, z=0.0),
        Displacement("blocks", "upper_top", x=0.0, y=0.0, z=Linear(-PUSH))),
        self_contacts=(SelfContact("blocks", "touching", **self_contact),))


def _explicit_job(degree: int) -> Job:
    return Job(_scene(_two_blocks(), degree), steps=StepControl(initial=0.05, max=0.05,
                                                                min=0.05),
               solver="explicit", explicit=ExplicitOptions(loading_time=2e-3))


@pytest.mark.parametrize("degree", [1, 2])
def test_blocks_pushed_together_carry_the_series_force(tmp_path, degree):
    """Once the gap closes, the blocks are two bars in series, compressed by what the
    penalty leaves of the push: the force is E A (push - gap - penetration) / (2 H)
    (nu = 0: uniaxial stress). Explicit, quasi-static loading; linear hexahedra (faces
    split in two triangles) and quadratic ones (in eight around the face's centre node,
    as the meso walls).

    A force off by more than 2% would mean the contact force is not what compresses the
    blocks (a wrong sign or a lost pair); a penetration above a tenth of an element, a
    penalty far softer than the elements.
    """
    s = simulate(_explicit_job(degree), tmp_path, "blocks", {})
    assert s["status"] == "completed", s["reason"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    force = -h["reaction_upper_top_z_N"][-1]
    penetration = h["self_contact_blocks_penetration_mm"][-1]
    expected = E * SIDE**2 * (PUSH - GAP - penetration) / (2 * HEIGHT)
    assert force == pytest.approx(expected, rel=0.02)
    assert s["metrics"]["self_contact_penetration_max_mm"] < 0.1 * HEIGHT / 2
    assert s["metrics"]["energy_balance_error_rel"] < 0.01


def test_implicit_run_stops_where_the_surface_meets_itself(tmp_path):
    """The implicit solver does not enforce self-contact: the run must stop, at the
    last state before the gap closes, saying so (not let the blocks pass through).

    A run that completes would mean interpenetration went unnoticed.
    """
    job = Job(_scene(_two_blocks()), steps=StepControl(initial=0.05, max=0.05, min=1e-3))
    s = simulate(job, tmp_path, "blocks", {})
    assert s["status"] == "failed"
    assert "self-contact is enforced by the explicit solver only" in s["reason"]
    closed = GAP / PUSH  # load parameter at which the gap closes
    assert closed - 0.05 - 1e-9 <= s["load_parameter_reached"] < closed


def test_a_node_found_deep_behind_a_face_starts_no_contact(tmp_path):
    """Blocks that overlap from the start by more than a contact may begin at (a tenth of
    the search depth): no node was ever in front of the other block's face, so none is in
    contact, and the upper block is pushed down without resistance. In a folding wall
    such nodes are across a fold or a junction; pushing them out flung them at 100 m/s.
    A force means the onset rule is gone.
    """
    overlap = 0.2  # mm, the search depth is 0.5 (half the 1 mm elements)
    job = Job(_scene(_two_blocks(gap=-overlap)), steps=StepControl(initial=0.1, max=0.1,
                                                                   min=0.1),
              solver="explicit", explicit=ExplicitOptions(loading_time=1e-3))
    s = simulate(job, tmp_path, "blocks", {})
    assert s["status"] == "completed", s["reason"]
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    assert np.all(h["self_contact_blocks_pairs"] == 0)
    assert abs(h["reaction_upper_top_z_N"][-1]) < 1e-3 * E * SIDE**2 * PUSH / (2 * HEIGHT)


def test_a_pair_starts_unloaded_and_keeps_its_force_only_on_a_face_alike():
    """The pair rules of the penalty, on one slave node and three fixed triangles (a
    face, one tilted 10 degrees from it, one at 90 degrees: a fold). A pair found
    penetrated starts with no force; the penetration it gains after that pushes, k per
    mm; moving onto the tilted triangle keeps the force, onto the folded one starts
    again from zero. A pair that starts with the force of a depth it did not build up
    puts energy into the walls (``meso_crushing``: 61 N mm by 1.9 mm of stroke, and
    wall nodes at 300 m/s, before this rule); a failure means that rule is gone.
    """
    from forming.contact.selfkernels import penalty_residual

    c, s10 = np.cos(np.radians(10.0)), np.sin(np.radians(10.0))
    x = np.array([[0.0, 0.0, 0.0],  # the slave
                  [-1, -1, 0], [3, -1, 0], [-1, 3, 0],  # face, normal +z
                  [-1, -1, 0], [-1 + 4 * c, -1, 4 * s10], [-1, 3, 0],  # tilted 10 deg
                  [0, -1, -1], [0, 3, -1], [0, -1, 3]], float)  # folded: normal +x
    tris = np.array([[1, 2, 3], [4, 5, 6], [7, 8, 9]], np.int64)
    normals = [np.array([0.0, 0.0, 1.0]), np.array([-s10, 0.0, c]), np.array([1.0, 0, 0])]
    mass = np.array([1.0] + [1e12] * 9)
    state = np.array([[-1.0, 0.0, 0.0]])
    k = 0.3  # scale m / dt^2 with m = 1 (the triangles' nodes do not move) and dt = 1

    def force(t: int, d: float) -> float:
        r = np.zeros((10, 3))
        penalty_residual(x, np.array([0]), np.array([t]), np.array([d]),
                         np.array([[1 / 3] * 3]), normals[t][None, :], tris, mass,
                         np.zeros((10, 3)), np.ones(10), k, 0.0, 1.0, state, r)
        return float(-r[0] @ normals[t])

    assert force(0, -0.02) == 0.0  # found 0.02 deep: starts unloaded
    assert force(0, -0.03) == pytest.approx(k * 0.01, rel=1e-12)
    assert force(1, -0.03) == pytest.approx(k * 0.01, rel=1e-12)  # onto a face alike
    assert force(2, -0.03) == 0.0  # across the fold: starts again


@pytest.mark.parametrize("field,value", [("depth", -1.0), ("stiffness", 2.0),
                                         ("stiffness", 0.0)])
def test_bad_self_contact_settings_name_the_field(field, value):
    """A negative search depth or a penalty fraction outside (0, 1] is refused by name."""
    with pytest.raises(InputError, match=f"self_contact.{field}"):
        SelfContact("blocks", "touching", **{field: value})


@pytest.mark.mpi
def test_two_ranks_give_the_serial_forces(tmp_path):
    """The quadratic blocks on 2 ranks: the partition cuts the contact surface, whose
    nodes, triangles and forces then live on both ranks (gathered positions, summed
    forces). The same increments add the same forces in another order: the reaction
    history agrees to 1e-9 of the largest force. A larger difference means a pair found
    twice or missed across the partition.
    """
    serial = simulate(_explicit_job(2), tmp_path / "serial", "blocks", {})
    proc = run_mpi([__file__, str(tmp_path / "parallel")], timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    parallel = json.loads((tmp_path / "parallel" / "summary.json").read_text())
    assert serial["status"] == parallel["status"] == "completed" and parallel["ranks"] == 2

    def force(path: Path) -> np.ndarray:
        h = np.genfromtxt(path / "history.csv", delimiter=",", names=True)
        return h["reaction_upper_top_z_N"]

    a, b = force(tmp_path / "serial"), force(tmp_path / "parallel")
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * np.max(np.abs(a)))


if __name__ == "__main__":  # the 2-rank run of the test above
    simulate(_explicit_job(2), Path(sys.argv[1]), "blocks", {})


def _crumpled_sheet(n: int = 31, seed: int = 7):
    """A crumpled 10 x 10 mm sheet of triangles, two per cell, and its node-cell pairs."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.linspace(0, 10, n), np.linspace(0, 10, n), indexing="ij")
    x = np.column_stack([gx.ravel(), gy.ravel(), 0.3 * np.sin(gx.ravel()) * np.cos(gy.ravel())])
    x += rng.normal(scale=0.05, size=x.shape)
    quads = [(i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1)
             for i in range(n - 1) for j in range(n - 1)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], np.int64)
    tri_cell = np.arange(len(tris), dtype=np.int64) // 2
    return (x, tris, tri_cell, *_node_cells(len(x), tris, tri_cell))


def _node_cells(n: int, tris: np.ndarray, tri_cell: np.ndarray):
    """The cells each node belongs to, in CSR form (offsets, cells)."""
    node_cells = [[] for _ in range(n)]
    for t, tri in enumerate(tris):
        for v in tri:
            node_cells[v].append(tri_cell[t])
    ptr = np.cumsum([0] + [len(c) for c in node_cells]).astype(np.int64)
    cells = np.array([c for cs in node_cells for c in cs], np.int64)
    return ptr, cells


@numba.njit(cache=True)
def _pairs_within(x, tris, tri_cell, ptr, cells, tri_dead, slaves, reach):
    """Brute force: (n_slaves, n_triangles), whether the triangle's nearest point lies
    within ``reach`` of the slave (neither on its cells nor eroded)."""
    out = np.zeros((slaves.size, tris.shape[0]), dtype=np.bool_)
    for i in range(slaves.size):
        s = slaves[i]
        for t in range(tris.shape[0]):
            if not tri_dead[t] and not _excluded(s, t, tris, tri_cell, ptr, cells):
                out[i, t] = distance2(x, tris, t, x[s, 0], x[s, 1], x[s, 2]) <= reach**2
    return out


def test_the_search_finds_what_a_brute_force_search_finds():
    """The binned candidate search returns, node by node, exactly the triangles a test of
    every node against every triangle returns, on a crumpled sheet of 1,800 triangles with
    one face stretched across the whole sheet (a cracked wall), one eroded, and a fragment
    flung 500 mm off with a node that meets it there. A failure
    means self-contacts are missed (a fold passes through a wall) or the list is padded.
    """
    x, tris, tri_cell, ptr, cells = _crumpled_sheet()
    n = 31
    x[0] = (-20.0, -20.0, 5.0)  # node 0 flung away: its triangle spans the sheet
    # a fragment flung 500 mm off (the last quad's nodes) and a node that meets it there:
    # both outside the grid's box, in its border cells
    far = np.array([(n - 2) * n + n - 2, (n - 1) * n + n - 2, (n - 1) * n + n - 1,
                    (n - 2) * n + n - 1])
    x[far] += (400.0, 300.0, -200.0)
    x[5] = x[far].mean(axis=0) + (0.0, 0.0, 0.1)
    tri_dead = np.zeros(len(tris), bool)
    tri_dead[100] = True
    slaves = np.arange(len(x), dtype=np.int64)
    reach = 0.4
    offsets, found = candidates(x, tris, tri_cell, ptr, cells, slaves, reach, tri_dead,
                                np.zeros(len(x), bool))
    near = _pairs_within(x, tris, tri_cell, ptr, cells, tri_dead, slaves, reach)
    for s in slaves:
        assert list(found[offsets[s]:offsets[s + 1]]) == list(np.flatnonzero(near[s])), s
    assert offsets[-1] > 0
    assert offsets[6] > offsets[5]  # the node by the far fragment found it
    # the stretched face is listed only where it passes, not for its whole bounding sphere
    stretched = np.flatnonzero((tris == 0).any(axis=1))
    assert np.isin(found, stretched).sum() < 0.2 * len(x)


def test_the_list_kept_as_sheets_close_holds_every_pair_in_reach():
    """The Verlet list kept by partial searches (a fragment flung through a sheet; then
    the sheets' own motion) and now and then a full one, with cells eroding on the way,
    holds at every one of 200 increments each pair a brute-force test finds within the
    hit radius, and no eroded face, while one crumpled sheet closes onto another. A
    failure means a contact the search misses: a fold passes through a wall. Both kinds
    of search must have run, or the test proves nothing of one.
    """
    xa, tris_a, cell_a, _, _ = _crumpled_sheet(n=21, seed=3)
    n_a = len(xa)
    x = np.vstack([xa, xa[::-1] + (0.1, 0.0, 0.35)])  # the upper sheet faces the lower
    tris = np.vstack([tris_a, tris_a + n_a])
    tri_cell = np.concatenate([cell_a, cell_a + cell_a.max() + 1])
    ptr, cells = _node_cells(len(x), tris, tri_cell)
    rng = np.random.default_rng(11)
    depth = 0.1
    hit = 1.12 * depth
    slaves = np.arange(0, len(x), 2, dtype=np.int64)
    # partial searches whatever they cost, and a full one now and then
    verlet = VerletList(tris, tri_cell, ptr, cells, slaves, hit, depth, partial_cost=1e9)
    fling = n_a + rng.choice(n_a, 3, replace=False)  # upper-sheet nodes shot down and across
    speed = np.column_stack([rng.normal(scale=0.04, size=(3, 2)), np.full(3, -0.01)])
    tri_dead = np.zeros(len(tris), bool)
    met = 0
    for step in range(200):
        x[n_a:, 2] -= 0.0015  # the upper sheet closes, slower than the margin per increment
        x += rng.normal(scale=0.0005, size=x.shape)
        x[fling] += speed
        if step % 80 == 79:
            verlet.forget()
        if step in (50, 120):  # cells erode: their faces and lone nodes leave
            tri_dead[rng.choice(len(tris), 40, replace=False)] = True
            alive = np.zeros(len(x), bool)
            alive[tris[~tri_dead].ravel()] = True
            verlet.erode(tri_dead, ~alive)
        offsets, cand = verlet.update(x)
        near = _pairs_within(x, tris, tri_cell, ptr, cells, tri_dead, slaves, hit)
        met += int(near.any(axis=1).sum())
        for i, s in enumerate(slaves):
            listed = cand[offsets[i]:offsets[i + 1]]
            assert not tri_dead[listed].any(), (step, s)
            if not verlet.node_dead[s]:
                missing = set(np.flatnonzero(near[i])) - set(listed)
                assert not missing, (step, s, missing)
    full, partial = verlet.searches
    assert full == 3 and partial > 20, verlet.searches
    assert met > 1000  # the sheets did meet
