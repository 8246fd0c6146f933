"""How many of the compiled modules in an FFCx cache hold the same code (docs/performance.md).

DOLFINx names each compiled form or expression by a hash of its UFL signature and
compile options, and keeps ``libffcx_*.c`` beside the built library. Two modules whose C
source is the same once the hashes are blanked out hold the same code under two names:
a signature that differs in something the code does not depend on. Prints the number of
modules, of distinct codes, of distinct codes with the floating-point literals blanked
too (what a ``fem.Constant`` instead of a literal would share), and the largest groups.

Usage: ``python benchmarks/ffcx_cache_duplicates.py [CACHE_DIR]`` (default
``$XDG_CACHE_HOME/fenics``, else ``~/.cache/fenics``; run the test suite into an empty
one first: ``XDG_CACHE_HOME=DIR``).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
from collections import defaultdict
from pathlib import Path

HASH = re.compile(r"[0-9a-f]{40}")
LITERAL = re.compile(r"\b\d+\.\d*(e[-+]?\d+)?\b")


def _key(text: str) -> str:
    return hashlib.sha1(text.encode()).hexdigest()


def main() -> None:
    default = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "fenics"
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("cache", type=Path, nargs="?", default=default)
    parser.add_argument("--groups", type=int, default=5, help="largest groups to list")
    args = parser.parse_args()
    sources = sorted(args.cache.glob("libffcx_*.c"))
    if not sources:
        raise SystemExit(f"no libffcx_*.c in {args.cache}: not an FFCx cache, or empty")
    same: dict[str, list[Path]] = defaultdict(list)
    up_to_literals: set[str] = set()
    for path in sources:
        code = HASH.sub("H", path.read_text())
        same[_key(code)].append(path)
        up_to_literals.add(_key(LITERAL.sub("L", code)))
    kinds = defaultdict(int)
    for path in sources:
        kinds[path.name.split("_")[1]] += 1
    print(f"{args.cache}: {len(sources)} modules "
          f"({', '.join(f'{n} {k}' for k, n in sorted(kinds.items()))}), "
          f"{len(same)} distinct codes, {len(up_to_literals)} distinct up to literals")
    for group in sorted(same.values(), key=len, reverse=True)[:args.groups]:
        if len(group) > 1:
            print(f"  {len(group)} copies: {group[0].name}")


if __name__ == "__main__":
    main()
