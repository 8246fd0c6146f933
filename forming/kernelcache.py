"""numba's on-disk cache, one folder per version of the package's sources.

numba keeps a compiled kernel on disk and trusts it while the file that defines the
kernel is unchanged. It does not look at the kernels it calls from other modules:
after an edit of ``forming/contact/slidekernels.py``, the cached
``slidebatch.jacobian_all`` went on running the pair kernel of before the edit (seen
2026-11-28: the same run, the same bits, none of the edit's speed). A cache that can
run code other than the sources is a hazard, so the package's kernels are cached under
a folder named by a digest of every source file of the package: any edit, or another
revision checked out, starts a fresh folder, and the folder of a revision comes back
when the revision does.

The base folder is ``NUMBA_CACHE_DIR`` as the user set it (``scripts/dev.sh``:
``.cache/numba``), else ``$XDG_CACHE_HOME/forming/numba`` (``~/.cache``). A process
started by one that made the choice (an MPI rank, a test worker) inherits
``NUMBA_CACHE_DIR`` already ending in the digest, and keeps it. Folders of other digests
unused for 30 days are removed when a new one is made.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from pathlib import Path

_KEEP_DAYS = 30
_PACKAGE = Path(__file__).resolve().parent


def source_digest(package: Path = _PACKAGE) -> str:
    """A digest of every Python source file of the package (paths and contents)."""
    h = hashlib.sha1()
    for path in sorted(package.rglob("*.py")):
        h.update(path.relative_to(package).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


def base_dir(digest: str | None = None) -> Path:
    """The folder that holds one cache folder per digest."""
    digest = digest or source_digest()
    base = os.environ.get("NUMBA_CACHE_DIR")
    if base:
        path = Path(base)
        return path.parent if path.name == digest else path
    cache_home = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache_home) / "forming" / "numba"


def cache_dir() -> Path:
    """This version's cache folder (not created)."""
    digest = source_digest()
    return base_dir(digest) / digest


def _prune(base: Path, keep: Path) -> None:
    """Remove the other digests' folders that nothing has written to for a while."""
    old = time.time() - _KEEP_DAYS * 86400
    for folder in base.iterdir():
        if (folder != keep and folder.is_dir() and len(folder.name) == 16
                and all(c in "0123456789abcdef" for c in folder.name)
                and folder.stat().st_mtime < old):
            shutil.rmtree(folder, ignore_errors=True)


def configure() -> Path:
    """Point numba's cache at this version's folder (before any kernel is defined)."""
    digest = source_digest()
    base = base_dir(digest)
    folder = base / digest
    if not folder.is_dir():
        try:
            folder.mkdir(parents=True, exist_ok=True)
            _prune(base, folder)
        except OSError:  # a read-only place: numba then compiles without a cache
            pass
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    import sys

    config = getattr(sys.modules.get("numba"), "config", None)
    if config is not None:  # numba was imported already: its setting too
        config.CACHE_DIR = str(folder)
    return folder
