"""The command line explains itself: list, version, per-case help, exit codes."""

from __future__ import annotations

import dataclasses

from helpers import run_python

from forming.case import load_case
from forming.errors import EXIT_CODES

CLI = ["-m", "forming.cli"]


def test_forming_list_names_every_case_with_a_line():
    """forming list: one line per case script, with the first line of its docstring."""
    proc = run_python([*CLI, "list"], timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    names = [line.split()[0] for line in lines]
    assert {"core_compression", "hemisphere", "core_crushing", "skin_sled"} <= set(names)
    assert any("Hemisphere forming" in line for line in lines)


def test_forming_version_names_the_package_and_commit():
    """forming --version: the package version (and the git commit in a checkout)."""
    proc = run_python([*CLI, "--version"], timeout=60)
    assert proc.returncode == 0 and proc.stdout.startswith("forming 0.")


def test_run_case_help_lists_every_parameter_with_type_default_and_meaning():
    """forming run hemisphere --help: every field of its Params with its type, default and
    the meaning from the source, plain text (no reStructuredText markup), and the
    settings every case takes."""
    proc = run_python([*CLI, "run", "hemisphere", "--help"], timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = proc.stdout
    params = load_case("hemisphere").Params
    for f in dataclasses.fields(params):
        line = next(row for row in text.splitlines() if row.split()[:1] == [f.name])
        assert len(line.split()) >= 4, line  # name, type, default, meaning
    assert "stroke" in text and "punch travel [mm]" in text
    assert "explicit.loading_time" in text and "``" not in text


def test_top_level_help_is_plain_and_gives_exit_codes():
    proc = run_python([*CLI, "--help"], timeout=60)
    assert proc.returncode == 0
    assert "``" not in proc.stdout and ":mod:" not in proc.stdout
    assert "130 interrupted" in proc.stdout


def test_bad_input_names_what_the_user_typed_and_exits_2(tmp_path):
    """A zero thickness is refused as --set thickness (not an internal mesh field), an
    infinite strain as non-finite, each with exit code 2 and one line, no traceback."""
    for setting, expected in (("thickness=0", "--set thickness: must be > 0"),
                              ("strain=inf", "--set strain: must be a finite number")):
        proc = run_python([*CLI, "run", "core_compression", "--out", str(tmp_path / "x"),
                           "--set", setting], timeout=60)
        assert proc.returncode == EXIT_CODES["input"], proc.stderr[-2000:]
        assert expected in proc.stderr and "Traceback" not in proc.stderr


def test_a_mistyped_option_is_refused_not_passed_to_petsc(tmp_path):
    """``--set-py`` (two dashes, unknown) is an input error naming it, exit code 2, before
    any run; PETSc would have taken it silently as an option nobody reads."""
    out = tmp_path / "x"
    proc = run_python([*CLI, "run", "core_compression", "--out", str(out),
                       "--set-py", "strain=0.1"], timeout=60)
    assert proc.returncode == EXIT_CODES["input"], proc.stderr[-2000:]
    assert "unknown option '--set-py'" in proc.stderr and "Traceback" not in proc.stderr
    assert not (out / "history.csv").exists()
