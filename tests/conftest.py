"""Shared fixtures. Importing forming.compat first loads PETSc the right way.

Helper functions live in ``helpers.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import forming.compat  # noqa: F401

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO
