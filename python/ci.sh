#!/usr/bin/env bash
# Builds the Python package from this checkout and runs its tests, on a fresh machine too:
#   bash python/ci.sh
# 1. a virtual environment (python/.venv, or $LINCAL_VENV), with maturin, pytest, numpy;
# 2. the package, exactly as a user installs it: `pip install ./python`;
# 3. the `lincal` binary the tests compare with (`cargo build --release --bin lincal`, a no-op
#    when it is built; or $LINCAL_BIN);
# 4. pytest on python/tests (the shared reference cases are read from ../shared/cases, or
#    $LINCAL_CASES).
# Honours CARGO_TARGET_DIR (the package's build uses it too); $PYTHON picks the interpreter.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"
python="${PYTHON:-python3}"
venv="${LINCAL_VENV:-$here/.venv}"

fail() {
    echo "python/ci.sh: error: $*" >&2
    exit 1
}
step() { echo "python/ci.sh: $*" >&2; }

command -v "$python" >/dev/null 2>&1 ||
    fail "no $python on PATH: install Python 3.9 or newer (Debian: apt-get install python3 python3-venv python3-dev)"
"$python" -c 'import sys; sys.exit(sys.version_info < (3, 9))' ||
    fail "$("$python" --version 2>&1) is too old: lincal needs Python 3.9 or newer"
command -v cargo >/dev/null 2>&1 ||
    fail "no cargo on PATH: the package is built from Rust sources (install rustup, https://rustup.rs)"

if [ ! -x "$venv/bin/python" ]; then
    step "creating the virtual environment $venv"
    if ! "$python" -c 'import venv, ensurepip' >/dev/null 2>&1; then
        fail "the venv module (with ensurepip) is missing for $python; on Debian or Ubuntu:
    apt-get update && apt-get install -y python3-venv
(or python3.X-venv for your version), then run this script again"
    fi
    rm -rf "$venv"
    "$python" -m venv "$venv" ||
        fail "cannot create $venv (on Debian or Ubuntu: apt-get install -y python3-venv)"
fi
vpy="$venv/bin/python"

step "installing maturin, pytest, numpy"
# pip 21.3 or newer builds a local directory in place; older ones copy python/ alone to a
# temporary folder, where the path dependency ../lincal-core is missing.
"$vpy" -m pip install --quiet --disable-pip-version-check --upgrade "pip>=21.3" ||
    fail "cannot install pip>=21.3 from the package index"
"$vpy" -m pip install --quiet --disable-pip-version-check maturin pytest numpy ||
    fail "cannot install maturin, pytest, numpy from the package index"

step "building and installing the package: pip install ./python"
(cd "$repo" && "$vpy" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./python) ||
    fail "pip install ./python failed (the Rust build's messages are above)"
"$vpy" -c 'import lincal; print("python/ci.sh: lincal", lincal.__version__, "from", lincal.__file__)' >&2

if [ -z "${LINCAL_BIN:-}" ]; then
    step "building the lincal binary the tests compare with"
    (cd "$repo" && cargo build --release --quiet --bin lincal) || fail "cargo build --release --bin lincal failed"
    target="${CARGO_TARGET_DIR:-$repo/target}"
    case "$target" in /*) ;; *) target="$repo/$target" ;; esac
    export LINCAL_BIN="$target/release/lincal"
fi
[ -x "$LINCAL_BIN" ] || fail "no lincal binary at $LINCAL_BIN"
export LINCAL_REQUIRE_CLI=1

step "pytest"
cd "$here"
exec "$vpy" -m pytest -q tests "$@"
