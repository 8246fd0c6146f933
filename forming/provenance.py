"""Where a run came from: start time, command line, package version and git commit."""

from __future__ import annotations

import datetime
import platform
import subprocess
import sys
from pathlib import Path

from forming import __version__

REPO = Path(__file__).resolve().parent.parent


def now() -> str:
    """The current UTC time, ISO 8601 to the second."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def git_commit() -> dict[str, str | bool | None]:
    """The checkout's commit and whether tracked files differ from it (None outside git)."""
    if not (REPO / ".git").exists():
        return {"commit": None, "dirty": None}

    def git(*args: str) -> str | None:
        try:
            out = subprocess.run(["git", "-C", str(REPO), *args], capture_output=True,
                                 text=True, timeout=10, check=True)
        except (OSError, subprocess.SubprocessError):
            return None
        return out.stdout.strip()

    commit = git("rev-parse", "HEAD")
    status = git("status", "--porcelain", "--untracked-files=no")
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def run_record() -> dict:
    """The run's provenance (call on rank 0: it may run git)."""
    return {"started": now(), "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
            "forming": __version__, "git": git_commit(), "host": platform.node()}
