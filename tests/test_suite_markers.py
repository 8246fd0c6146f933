"""The suite's own bookkeeping: tests that launch MPI runs carry the ``mpi`` marker."""

from __future__ import annotations

import ast

from helpers import REPO


def _marks(node: ast.FunctionDef) -> set[str]:
    """Names of the ``pytest.mark.X`` decorators of a test and of its parameter sets."""
    out = set()
    for sub in ast.walk(ast.Module(body=list(node.decorator_list), type_ignores=[])):
        if (isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Attribute)
                and sub.value.attr == "mark"):
            out.add(sub.attr)
    return out


def _launchers(tree: ast.Module) -> set[str]:
    """``run_mpi`` and the module-level functions that call it."""
    names = {"run_mpi"}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and any(
                isinstance(n, ast.Name) and n.id == "run_mpi" for n in ast.walk(node)):
            names.add(node.name)
    return names


def test_every_test_that_launches_mpirun_is_marked_mpi():
    """The marker says which tests launch ``mpirun -n 2`` (``-m mpi`` selects them, ``-m
    "not mpi"`` leaves them out, on a machine or in an environment without MPI). A
    failure names a test that calls ``run_mpi`` (itself or through a helper of its
    module) without the marker."""
    unmarked = []
    for path in sorted((REPO / "tests").glob("test_*.py")):
        tree = ast.parse(path.read_text())
        launchers = _launchers(tree)
        for node in tree.body:
            if not (isinstance(node, ast.FunctionDef) and node.name.startswith("test_")):
                continue
            calls = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
            if calls & launchers and "mpi" not in _marks(node):
                unmarked.append(f"{path.name}::{node.name}")
    assert unmarked == [], unmarked
