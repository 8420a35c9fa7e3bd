#!/usr/bin/env bash
# The Python package's tests: a venv under target/, maturin, pytest, pandas, numpy and
# dask[distributed] from pip, the wheel of python/ built and installed (`pip install ./python`),
# then pytest on python/tests (among them the Dask batch on a two-worker LocalCluster against
# `aerosid batch`) and scripts/bench (the benchmark's scoring; its pysindy/sysidentpy tests skip
# here). pytest's exit code 5 ("no tests collected") fails like any other.
#
# The `aerosid` command the tests compare with: $AEROSID, else target/debug/aerosid (built here
# if `cargo test --workspace` has not built it). The extension's own build goes to
# target/python (its own workspace: python/Cargo.toml says why).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

TARGET="$(realpath -m "${CARGO_TARGET_DIR:-target}")"
VENV="$TARGET/venv"
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
"$VENV/bin/pip" install --quiet --upgrade pip
"$VENV/bin/pip" install --quiet maturin pytest pandas numpy "dask[distributed]"

export AEROSID="${AEROSID:-$TARGET/debug/aerosid}"
if [ ! -x "$AEROSID" ]; then
    cargo build -p aerosid --bin aerosid
fi

# maturin (pip's build backend, the venv's own: no isolated build environment) runs cargo in
# python/; its target folder is kept between runs. numpy, its one dependency, is installed above.
PATH="$VENV/bin:$PATH" CARGO_TARGET_DIR="$TARGET/python" "$VENV/bin/pip" install --quiet --no-build-isolation --force-reinstall --no-deps ./python

set +e
"$VENV/bin/python" -m pytest -q python/tests scripts/bench
code=$?
set -e
if [ "$code" -eq 5 ]; then
    echo "python-tests: pytest collected no tests" >&2
    exit 1
fi
exit "$code"
