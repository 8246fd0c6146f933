"""Shared fixtures. Importing forming.compat first loads PETSc the right way.

Helper functions live in ``helpers.py``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import forming.compat  # noqa: F401

REPO = Path(__file__).resolve().parent.parent

# The suite asserts physics: the cases' 3D views and sections (about a second each, an
# off-screen render, in about 40 runs) are drawn only by the tests that check them (the
# ``pictures`` fixture), here and in the processes the tests start. FORMING_PICTURES=1
# in the environment draws them in every run.
os.environ.setdefault("FORMING_PICTURES", "0")


@pytest.fixture
def pictures(monkeypatch):
    """The runs of this test, and the processes it starts, draw their pictures."""
    monkeypatch.setenv("FORMING_PICTURES", "1")


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO
