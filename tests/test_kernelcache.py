"""The numba cache folder follows the package's sources (forming/kernelcache.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

from forming import kernelcache


def test_an_edit_anywhere_in_the_sources_gives_another_cache_folder(tmp_path):
    """An edit of one kernel module changes the folder, so no caller runs stale code.

    numba invalidates a cached kernel when its own file changes, not when a kernel it
    calls from another module does (slidebatch calls slidekernels). A failure means an
    edited kernel could be run by its callers in its old form.
    """
    package = tmp_path / "pkg"
    shutil.copytree(Path(kernelcache.__file__).parent / "contact", package / "contact")
    before = kernelcache.source_digest(package)
    assert kernelcache.source_digest(package) == before  # the same sources, the same folder
    callee = package / "contact" / "slidekernels.py"
    callee.write_text(callee.read_text() + "\n# an edit\n")
    assert kernelcache.source_digest(package) != before


def test_child_processes_keep_the_folder_they_inherit(tmp_path, monkeypatch):
    """An MPI rank or test worker inherits ``NUMBA_CACHE_DIR`` already ending in the digest.

    A failure means every child process would nest another folder and compile anew.
    """
    import numba

    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)  # restored after
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "base"))
    first = kernelcache.configure()
    assert first == tmp_path / "base" / kernelcache.source_digest()
    assert kernelcache.configure() == first  # the child's view: NUMBA_CACHE_DIR is `first`
