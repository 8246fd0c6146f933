"""Write the demonstrator's matched tools (STEP and STL) and its trim line.

The shipped component's dimensions are in one place, ``forming.demonstrator.geometry
.Component``; the solids are built with gmsh's OpenCASCADE kernel
(``forming.demonstrator.tools``). ``cases/demonstrator.py`` writes the same files on
first use under ``meshes/generated/<component key>/``.

Run: ``python meshes/demonstrator_tools.py [--out DIR] [--set depth=40 ...]``
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import forming  # noqa: F401  (PETSc and gmsh the project's way)
from forming.demonstrator.geometry import Component
from forming.demonstrator.tools import tool_files
from forming.errors import InputError
from forming.tooling import generated_dir


def _component(assignments: list[str]) -> Component:
    values = {}
    names = {f.name: f for f in dataclasses.fields(Component)}
    for text in assignments:
        key, _, value = text.partition("=")
        if key not in names:
            raise InputError(f"--set {key}", f"unknown; one of {sorted(names)}")
        try:
            parts = [float(v) for v in value.split(",")]
        except ValueError as exc:
            raise InputError(f"--set {key}", f"not a number: {value!r}") from exc
        values[key] = tuple(parts) if len(parts) > 1 else parts[0]
    return Component(**values)


def main() -> None:
    """Parse the command line and write the files."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="folder (default: the cache)")
    parser.add_argument("--set", dest="assignments", action="append", default=[],
                        help="a Component dimension, e.g. depth=40 or rim=460,340")
    args = parser.parse_args()
    component = _component(args.assignments)
    out = args.out or generated_dir() / component.key()
    for name, path in tool_files(out, component).items():
        print(f"{name}: {path}")


if __name__ == "__main__":
    main()
