#!/usr/bin/env bash
# Developer entry point for `forming`.
#
# Usage: scripts/dev.sh {main|core|test|validate|bench|shell} [args...]
#
# Ensures the repo-local venv (.venv) exists and matches requirements.lock +
# pyproject.toml (reinstall only when their sha256 changes), sets up the runtime
# environment (caches, thread counts, headless matplotlib) and runs the command.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$repo/.venv"
stamp="$venv/.forming-stamp"
uv_version=0.13.9  # the installer of the venv (a tool, not a dependency of the package)

usage() {
    echo "usage: scripts/dev.sh {main|core|test|validate|bench|shell} [args...]" >&2
    exit 2
}

die() {
    echo "dev.sh: error: $*" >&2
    exit 1
}

# --- locate a Python 3.12 interpreter ---------------------------------------
is_py312() {
    [[ -n "$1" ]] && "$1" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))' \
        >/dev/null 2>&1
}

find_python() {
    local cand tried=()

    if [[ -n "${FORMING_PYTHON:-}" ]]; then
        tried+=("\$FORMING_PYTHON=$FORMING_PYTHON")
        if is_py312 "$FORMING_PYTHON"; then echo "$FORMING_PYTHON"; return; fi
    else
        tried+=("\$FORMING_PYTHON (unset)")
    fi

    # python3.12 resolved from the repo root, so pyenv's .python-version applies.
    tried+=("python3.12 (from $repo)")
    cand="$(cd "$repo" && command -v python3.12 2>/dev/null || true)"
    if [[ -n "$cand" ]] && (cd "$repo" && is_py312 "$cand"); then
        # Resolve a pyenv shim to the real binary so the venv does not depend on cwd.
        cand="$(cd "$repo" && "$cand" -c 'import sys; print(sys.executable)')"
        echo "$cand"; return
    fi

    tried+=("pyenv which python3.12")
    if command -v pyenv >/dev/null 2>&1; then
        cand="$(cd "$repo" && pyenv which python3.12 2>/dev/null || true)"
        if is_py312 "$cand"; then echo "$cand"; return; fi
    fi

    tried+=("uv python find 3.12")
    if command -v uv >/dev/null 2>&1; then
        cand="$(uv python find 3.12 2>/dev/null || true)"
        if is_py312 "$cand"; then echo "$cand"; return; fi
    fi

    {
        echo "dev.sh: error: no Python 3.12 interpreter found. Tried:"
        printf '  - %s\n' "${tried[@]}"
        echo "Set FORMING_PYTHON=/path/to/python3.12 or install 3.12 (pyenv install 3.12)."
    } >&2
    exit 1
}

# --- ensure the venv is present and up to date -------------------------------
ensure_venv() {
    local want have=""
    [[ -f "$repo/requirements.lock" ]] || die "missing $repo/requirements.lock"
    [[ -f "$repo/pyproject.toml" ]] || die "missing $repo/pyproject.toml"
    want="$(cat "$repo/requirements.lock" "$repo/pyproject.toml" | sha256sum | cut -d' ' -f1)"

    if [[ -x "$venv/bin/python" && -f "$stamp" ]]; then
        have="$(<"$stamp")"
        [[ "$have" == "$want" ]] && return 0
    fi

    if [[ ! -x "$venv/bin/python" ]]; then
        local py
        py="$(find_python)"
        echo "dev.sh: creating $venv with $py" >&2
        "$py" -m venv "$venv" || die "venv creation failed"
    fi

    echo "dev.sh: installing dependencies into $venv (requirements.lock changed or first run)" >&2
    rm -f "$stamp"
    # uv sets the venv up in about 22 s where pip takes about 73 (`echo exit | bash
    # scripts/dev.sh shell` in a fresh clone, 2026-12-03, the same 56 packages); pip stays
    # the fallback where uv cannot be had. --compile-bytecode: pip writes the .pyc files
    # at install and uv does not; without them a process that may not write them
    # (PYTHONDONTWRITEBYTECODE, as on this machine) compiles dolfinx, numba,
    # matplotlib... from source at every start: 4.4 s instead of 1.6 to import them, in
    # every MPI rank, test worker and study run (12 s without the bytecode).
    local installer=(uv pip install --compile-bytecode --python "$venv/bin/python")
    if ! "$venv/bin/python" -m pip install -q "uv==$uv_version" >/dev/null 2>&1; then
        echo "dev.sh: uv $uv_version not installable; installing with pip" >&2
        installer=(python -m pip install)
    fi
    [[ -n "${PIP_FIND_LINKS:-}" && ${installer[0]} == uv ]] \
        && installer+=(--find-links "$PIP_FIND_LINKS")
    "$venv/bin/${installer[0]}" "${installer[@]:1}" -q -r "$repo/requirements.lock" \
        || die "installing requirements.lock failed (${installer[*]})"
    # setuptools is pinned in the lock (fenics-ffcx needs it), so build in-place.
    "$venv/bin/${installer[0]}" "${installer[@]:1}" -q --no-deps --no-build-isolation \
        -e "$repo" || die "installing the package (-e .) failed (${installer[*]})"
    echo "$want" >"$stamp"
}

# --- main ---------------------------------------------------------------------
[[ $# -ge 1 ]] || usage
cmd="$1"
shift
case "$cmd" in
    main | core | test | validate | bench | shell) ;;
    -h | --help | help) usage ;;
    *) echo "dev.sh: unknown command: $cmd" >&2; usage ;;
esac

ensure_venv
# The package's own bytecode, written even where PYTHONDONTWRITEBYTECODE is set (as on
# this machine): importing it from source costs every process about 0.5 s (2.1 s
# against 1.6 s with the libraries), and a suite starts hundreds. Changed files only.
"$venv/bin/python" -m compileall -q -j 0 "$repo/forming" >/dev/null \
    || die "compiling the package's bytecode failed"

export NUMBA_CACHE_DIR="$repo/.cache/numba"
mkdir -p "$NUMBA_CACHE_DIR"
# FEniCS JIT cache: default location (~/.cache/fenics) is kept on purpose.
export OMP_NUM_THREADS=1
export OPENBLAS_NUM_THREADS=1
export MPLBACKEND=Agg
export VIRTUAL_ENV="$venv"
export PATH="$venv/bin:$PATH"   # so mpirun (mpich wheel) and `forming` resolve to the venv

cd "$repo"

# On a cold numba cache, compile the kernels once, the two parts of `forming warmup` side
# by side, before the processes that need them (test workers, MPI ranks) would each
# compile them at the same time. Its third part, contact, is left to the tests: run after
# solvers, beside materials, it made the warm-up 70 s longer for a pytest 58 s shorter,
# within the machine's drift between the two runs (docs/performance.md, "The test suite
# from a fresh clone", 2026-12-03).
warm_kernels() {
    # the cache of this version of the sources (forming/kernelcache.py: one folder each)
    local dir
    dir="$("$venv/bin/python" -c 'from forming.kernelcache import cache_dir; print(cache_dir())')"
    [[ -n "$(find "$dir" -name '*.nbi' -print -quit 2>/dev/null)" ]] && return 0
    echo "dev.sh: cold numba cache: compiling the kernels (forming warmup, two parts)" >&2
    local a b rc=0
    "$venv/bin/forming" warmup --part materials & a=$!
    "$venv/bin/forming" warmup --part solvers & b=$!
    wait "$a" || rc=$?
    wait "$b" || rc=$?
    [[ $rc -eq 0 ]] || die "forming warmup failed (exit $rc)"
}

case "$cmd" in
    main)
        # the product's main job: the demonstrator part on a coarse mesh, 2 ranks
        # (a few minutes); the core's compression test is `dev.sh core`
        out=results/demonstrator_main
        warm_kernels
        "$venv/bin/mpirun" -n 2 "$venv/bin/forming" run demonstrator --out "$out" \
            --set element_size=60 "$@" || exit $?
        for png in shear_angle_map conformity_map section_y0; do
            echo "  $png: $out/$png.png"
        done
        ;;
    core)
        exec "$venv/bin/forming" run core_compression --out results/core_compression "$@"
        ;;
    test)
        rc=0
        "$venv/bin/ruff" check --quiet . || rc=$?
        # The solve forms at -O2, the warm-up's small models' too: on an empty FFCx cache
        # (~/.cache/fenics, a new machine) the suite compiles about a thousand forms, and
        # -O3 costs more compile time than the suite's short runs gain from it
        # (docs/performance.md, "The test suite from an empty FFCx cache").
        export FORMING_SOLVE_CFLAGS="${FORMING_SOLVE_CFLAGS:--O2 -march=native -g0}"
        warm_kernels
        # Two workers (CI has two cores; FORMING_TEST_WORKERS=0 runs them in this process),
        # each test given to whichever worker is free, so the longest ones do not queue.
        "$venv/bin/python" -m pytest -n "${FORMING_TEST_WORKERS:-2}" --dist worksteal "$@" \
            || { r=$?; [[ $rc -eq 0 ]] && rc=$r; }
        if [[ $rc -eq 5 ]]; then
            echo "dev.sh: error: pytest collected no tests (exit 5); failing so CI cannot pass silently" >&2
            exit 1
        fi
        exit "$rc"
        ;;
    validate)
        exec "$venv/bin/python" -m pytest -m slow "$@"
        ;;
    bench)
        exec "$venv/bin/python" benchmarks/run_all.py "$@"
        ;;
    shell)
        # shellcheck disable=SC1091
        exec bash --rcfile <(
            [[ -f "$HOME/.bashrc" ]] && echo "source '$HOME/.bashrc'"
            echo "source '$venv/bin/activate'"
        ) "$@"
        ;;
esac
