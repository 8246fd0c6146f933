"""Tools from surface meshes: query speed, and the hemisphere against its analytic tools.

Writes two sections:

* docs/performance.md ``closest_point``: 100,000 points within 5 mm of a
  100,000-triangle surface (a wavy 600 mm sheet), timed with the search we ship
  (fcpw's tree, then the exact double-precision point on the chosen triangle) and, when
  ``igl`` (libigl) can be imported, with libigl's AABB tree for comparison.
* docs/validation.md ``surface_tools``: ``hemisphere`` with blank holder on the
  12 x 12 x 3 mesh with analytic tools and with STL tools at several tessellations:
  punch-force error (RMS over the stroke and at the end), Newton iterations, wall time
  and the closest-point search's share.

Run alone (timings): ``python benchmarks/surface_tools.py`` (about 10 minutes);
``--only speed`` or ``--only hemisphere`` for one part (the speed figures in the docs
were taken with ``taskset -c 0`` and libigl importable, ``PYTHONPATH`` pointing at a
``pip install --target`` of it).
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np
from _report import REPO, machine, run_case_process, update_section

ANGLES = (10.0, 5.0, 2.5)  # tessellation: largest angle per triangle on curved faces [deg]
MESH = "cells=12,12,3"


def _wavy_sheet(n: int = 224) -> tuple[np.ndarray, np.ndarray]:
    x = np.linspace(-300.0, 300.0, n)
    X, Y = np.meshgrid(x, x)
    Z = 20.0 * np.sin(X / 60.0) * np.cos(Y / 80.0)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(),
                  idx[1:, :-1].ravel())
    faces = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    return np.c_[X.ravel(), Y.ravel(), Z.ravel()], faces


def _best(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def speed() -> list[str]:
    import fcpw

    from forming.contact.surface import SurfaceTool

    vertices, faces = _wavy_sheet()
    rng = np.random.default_rng(0)
    xy = rng.uniform(-280.0, 280.0, (100_000, 2))
    z = 20.0 * np.sin(xy[:, 0] / 60.0) * np.cos(xy[:, 1] / 80.0)
    points = np.c_[xy, z + rng.uniform(-5.0, 5.0, len(xy))]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sheet.stl"
        meshio.write(path, meshio.Mesh(vertices, [("triangle", faces)]), binary=True)
        t0 = time.perf_counter()
        tool = SurfaceTool(path, sheet=True)
        setup = time.perf_counter() - t0
    surface = tool.surface

    def build_fcpw():
        scene = fcpw.scene_3D()
        scene.set_object_count(1)
        scene.set_object_vertices(surface.vertices.astype(np.float32), 0)
        scene.set_object_triangles(surface.faces.astype(np.int32), 0)
        scene.build(fcpw.aggregate_type.bvh_surface_area, True)

    surface.query(points[:10])  # compiled
    ours = _best(lambda: surface.query(points))
    tree = _best(lambda: surface.closest_facets(points))
    lines = ["## Closest-point queries", "",
             f"`taskset -c 0 python benchmarks/surface_tools.py --only speed` on {machine()}, "
             f"one core: {len(points):,} points within 5 mm of a wavy sheet of "
             f"{len(surface.faces):,} triangles (600 mm square); best of three. Reading the "
             f"STL and preparing the surface (merging, checks, pseudo-normals, corner "
             f"normals, one-rings, tree) took {setup:.2f} s.", "",
             "| search | tree build [s] | query [s] | per point [us] |", "|---|---|---|---|",
             f"| fcpw 1.2.0 tree (single precision) | {_best(build_fcpw):.2f} | {tree:.3f} "
             f"| {1e6 * tree / len(points):.2f} |",
             f"| shipped: fcpw, then the exact point and direction on the one-ring (double "
             f"precision) | - | {ours:.3f} | {1e6 * ours / len(points):.2f} |"]
    try:
        import igl
    except ImportError:
        lines += ["", "(libigl not importable here: with `pip install libigl` on the path "
                  "the table gains its row.)"]
    else:
        V, F = np.ascontiguousarray(surface.vertices), np.ascontiguousarray(surface.faces)
        aabb = igl.AABB()
        igl_build = _best(lambda: aabb.init(V, F))
        P = np.ascontiguousarray(points)
        igl_query = _best(lambda: aabb.squared_distance(V, F, P))
        lines.append(f"| libigl 2.6 AABB, unsigned (not a dependency) | {igl_build:.2f} "
                     f"| {igl_query:.3f} | {1e6 * igl_query / len(points):.2f} |")
    lines += ["", "Target (issue 17): under 0.5 s for the query."]
    return lines


def _history(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    rows = list(csv.DictReader(open(folder / "history.csv")))
    return (np.array([float(r["t"]) for r in rows]),
            np.array([float(r["force_punch_z_N"]) for r in rows]))


def hemisphere() -> list[str]:
    lines = ["## Tools from surface meshes", "",
             f"`python benchmarks/surface_tools.py --only hemisphere` on {machine()}, run "
             "alone: `hemisphere` with blank holder on the 12 x 12 x 3 quarter mesh, the "
             "punch, die and holder built with OpenCASCADE (forming/cad.py; die and holder "
             "are discs 40 mm beyond the blank's corner), written as STL and read back as "
             "surface-mesh tools (`--set tools=stl --set tool_angle=A`). Force errors are "
             "against the analytic tools' run with the same tool stick law: RMS over the "
             "stroke relative to the RMS force, and at 50 mm.", "",
             "| stick law | tools | triangles (punch / die) | chord error on the punch [mm] "
             "| force RMS error | final force error | Newton iterations (rejected steps) "
             "| wall [s] | search [s] |", "|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for stick, angles in (("augmented", ANGLES), ("elastic_slip", (5.0,))):
            sets = ("blank_holder=true", MESH, f"tool_stick={stick}")
            ref = run_case_process("hemisphere", tmp / f"analytic-{stick}", sets=sets)
            t_ref, f_ref = _history(tmp / f"analytic-{stick}")
            scale = np.sqrt(np.mean(f_ref**2))
            tm = ref["timing"]
            lines.append(f"| {stick} | analytic | - | - | - | - "
                         f"| {tm['newton_iterations']} ({tm['rejected_steps']}) "
                         f"| {tm['wall_s']:.1f} | - |")
            for angle in angles:
                out = tmp / f"stl{angle:g}-{stick}"
                s = run_case_process("hemisphere", out, sets=(*sets, "tools=stl",
                                                              f"tool_angle={angle:g}"))
                t, f = _history(out)
                err = np.interp(t_ref, t, f) - f_ref
                chord = 50.0 * (1.0 - np.cos(np.radians(angle) / 2.0))
                tm = s["timing"]
                lines.append(f"| {stick} | STL, {angle:g} deg | {_triangle_counts(angle)} "
                             f"| {chord:.3f} | {np.sqrt(np.mean(err**2)) / scale:.2%} "
                             f"| {(f[-1] - f_ref[-1]) / f_ref[-1]:+.2%} "
                             f"| {tm['newton_iterations']} ({tm['rejected_steps']}) "
                             f"| {tm['wall_s']:.1f} | {tm['contact_search_s']:.1f} |")
    lines += ["", "The chord error is the nominal R (1 - cos(A/2)); gmsh's curvature sizing "
              "leaves some triangles larger (the test bounds the error by the largest edge). "
              "Wall times include the first run's compilation of the contact forms."]
    return lines


def _triangle_counts(angle: float) -> str:
    from forming.tooling import generated_dir

    hits = sorted((generated_dir() / "tools").glob(f"hemisphere-*-{angle:g}-25"))
    if not hits:
        return "?"
    counts = [len(meshio.read(hits[0] / f"{n}.stl").cells_dict["triangle"])
              for n in ("punch", "die")]
    return f"{counts[0]:,} / {counts[1]:,}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", choices=("speed", "hemisphere"))
    args = parser.parse_args()
    if args.only in (None, "speed"):
        lines = speed()
        update_section("closest_point", "\n".join(lines))
        print("\n".join(lines))
    if args.only in (None, "hemisphere"):
        lines = hemisphere()
        update_section("surface_tools", "\n".join(lines), REPO / "docs" / "validation.md")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
