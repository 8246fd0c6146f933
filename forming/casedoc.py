"""Help texts of the cases: what each one is, and every parameter it accepts.

A case's parameters are the fields of its frozen ``Params`` dataclass; each field's
meaning is the comment at the end of its line (``stroke: float = 50.0  # punch travel
[mm]``). Nothing here imports a case's dependencies: the listing reads the scripts'
docstrings without running them.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re
import textwrap
import types
import typing
from dataclasses import dataclass
from pathlib import Path

_COMMENT = re.compile(r"^\s+(\w+)\s*:.*?#\s*(.+?)\s*$", re.M)
_ATTRIBUTE = re.compile(r"^\s{8}(\w+):\s*(.+)$")


@dataclass(frozen=True)
class ParamDoc:
    """One parameter: its name, type, default and meaning."""

    name: str
    kind: str
    default: str
    meaning: str


def plain(text: str) -> str:
    """Docstring text without reStructuredText markup (``x`` and :role:`x`)."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", text)
    return text.replace("``", "")


def type_name(hint) -> str:
    """A type as a user types it: ``true|false``, ``a|b``, ``ints (a,b,c)``, ``number``."""
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        return "|".join(str(a) for a in typing.get_args(hint))
    if origin in (types.UnionType, typing.Union):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return f"{type_name(args[0])} or none"
    if origin is tuple:
        return f"{type_name(typing.get_args(hint)[0])}s (a,b,...)"
    return {bool: "true|false", int: "int", float: "number", str: "text"}.get(hint, str(hint))


def _default(value) -> str:
    if isinstance(value, tuple):
        return ",".join(str(v) for v in value)
    if isinstance(value, bool):
        return str(value).lower()
    return "none" if value is None else str(value)


def describe_params(params_cls: type) -> list[ParamDoc]:
    """Every field of a parameter dataclass with its type, default and meaning.

    Meanings come from the comment at the end of the field's line, or from an
    ``Attributes:`` section of the class docstring.
    """
    meanings = dict(_COMMENT.findall(inspect.getsource(params_cls)))
    attributes: dict[str, str] = {}
    current = None
    for line in (params_cls.__doc__ or "").splitlines():
        if m := _ATTRIBUTE.match(line):
            current = m.group(1)
            attributes[current] = m.group(2)
        elif current and line.startswith(" " * 12):
            attributes[current] += " " + line.strip()
        else:
            current = None
    for key, text in attributes.items():
        meanings.setdefault(key, text.split(". ")[0].rstrip("."))
    hints = typing.get_type_hints(params_cls)
    return [ParamDoc(f.name, type_name(hints[f.name]), _default(f.default),
                     plain(meanings.get(f.name, "")))
            for f in dataclasses.fields(params_cls)]


def format_params(docs: list[ParamDoc], prefix: str = "") -> str:
    """An aligned table of parameters, one per line."""
    rows = [(f"{prefix}{d.name}", d.kind, d.default, d.meaning) for d in docs]
    w = [max(len(r[i]) for r in rows) for i in range(3)]
    return "\n".join(f"  {r[0]:<{w[0]}}  {r[1]:<{w[1]}}  {r[2]:<{w[2]}}  {r[3]}".rstrip()
                     for r in rows)


def script_docstring(path: Path) -> str:
    """The module docstring of a case script, read without running it."""
    return ast.get_docstring(ast.parse(path.read_text())) or ""


def case_list(folder: Path) -> list[tuple[str, str]]:
    """(name, one-line description) of every case script in ``folder``."""
    out = []
    for path in sorted(folder.glob("*.py")):
        if not path.stem.startswith("_"):
            out.append((path.stem, plain(script_docstring(path).split("\n")[0])))
    return out


def case_help(name: str, doc: str, params_cls: type) -> str:
    """The help text of a case: what it is, its parameters, and the common settings."""
    from forming.solver.options import ExplicitOptions, NewtonOptions

    intro = plain(doc.split("\nRun:")[0].strip())
    return "\n".join([
        textwrap.fill(intro.split("\n\n")[0], 88), "",
        *(textwrap.fill(par, 88) + "\n" for par in intro.split("\n\n")[1:]),
        f"parameters (--set KEY=VALUE; forming run {name} --set cells=8,8,2 ...):",
        format_params(describe_params(params_cls)), "",
        "every case also takes:",
        "  solver              implicit|explicit  (case's)  Newton in load steps, or "
        "central differences in time",
        format_params(describe_params(ExplicitOptions), "explicit."),
        format_params([d for d in describe_params(NewtonOptions) if d.name != "petsc"],
                      "newton."),
        "  (explicit.* and newton.*: the case's own settings, e.g. loading_time or "
        "line_search, stay unless given)", "",
        "PETSc options follow as -forming_<option> value (e.g. -forming_snes_monitor).",
        "outputs, units and exit codes: README.md.",
    ])
