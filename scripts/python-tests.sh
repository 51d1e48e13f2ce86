#!/usr/bin/env bash
# Builds the hevo Python module and runs its tests (python/tests/, pytest), in a virtual
# environment under .tools/ whose packages come from PyPI at pinned versions. `.ci/run` calls
# it after `cargo test`; run it by hand the same way:
#
#   bash scripts/python-tests.sh              # every test
#   bash scripts/python-tests.sh -k evaluate  # arguments go to pytest
#
# The module is built as a wheel in the dev profile (`pip install ./python` builds release; the
# tests need no optimised engine beyond what the dev profile already optimises), into the
# workspace's target directory, so it reuses what `cargo test` compiled, and installed from
# the wheel with no package index. The `hevo` and `hevo-worker`
# binaries the tests compare with are the dev-profile ones.
#
# HEVO_TEST_TOOLS_DIR overrides .tools/, as for scripts/install-test-tools.sh.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
tools=${HEVO_TEST_TOOLS_DIR:-$repo/.tools}
venv=$tools/python-venv

# Pinned, so that every machine tests with the same packages. The examples' own (pycma,
# matplotlib) come with the module, as its `examples` extra, pinned in python/pyproject.toml.
packages=(
    maturin==1.16.0
    numpy==2.4.6
    pytest==9.2.0
)

log() {
    echo "python-tests: $*" >&2
}

command -v python3 >/dev/null || {
    log "needs python3 (with its venv module; on Debian: apt-get install python3-venv)"
    exit 1
}
if ! "$venv/bin/python" -c 'import pip' >/dev/null 2>&1; then
    rm -rf "$venv"
    python3 -m venv "$venv" || {
        log "python3 -m venv failed (on Debian: apt-get install python3-venv)"
        exit 1
    }
fi
pip() {
    PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1 "$venv/bin/python" -m pip "$@"
}
stamp=$venv/hevo-python-tests.txt
wanted=$(printf '%s\n' "${packages[@]}")
if [[ ! -f $stamp || $(<"$stamp") != "$wanted" ]]; then
    log "pip install ${packages[*]}"
    pip install --quiet "${packages[@]}"
    echo "$wanted" >"$stamp"
fi

cd "$repo"
log "cargo build -p hevo-cli -p hevo-worker"
cargo build --locked -p hevo-cli -p hevo-worker
target=${CARGO_TARGET_DIR:-$repo/target}

# The module is tested as users install it from a release artifact: `maturin build` makes the
# wheel (dev profile, into the workspace's target directory, so it reuses what `cargo build`
# compiled above), and pip installs it with no index at all, from that folder alone.
wheels=$tools/wheels
rm -rf "$wheels"
log "maturin build (dev profile) -> $wheels"
"$venv/bin/maturin" build --quiet --profile dev --locked \
    --manifest-path python/Cargo.toml --out "$wheels"
log "pip install --no-index --find-links $wheels hevo"
pip install --quiet --no-index --find-links "$wheels" --force-reinstall --no-deps hevo
# The examples' own packages, from PyPI at the pins of the `examples` extra in
# python/pyproject.toml (read from it, so the pins live in one place).
mapfile -t extras < <("$venv/bin/python" -c '
import tomllib
with open("python/pyproject.toml", "rb") as f:
    print("\n".join(tomllib.load(f)["project"]["optional-dependencies"]["examples"]))')
log "pip install ${extras[*]}"
pip install --quiet "${extras[@]}"

log "pytest python/tests"
HEVO_TEST_BIN_DIR=$target/debug "$venv/bin/python" -m pytest python/tests "$@"
