#!/usr/bin/env bash
# The benchmark against the peers at an equal false-alarm rate, end to end: the single-flight
# campaign (simulated turbulent flights with 20 clean ones, the JSBSim flights, the real flights)
# and the test cards (3 per kind, 20 clean, the JSBSim cards), each peer's knob swept, scored.
#
#     bash scripts/bench/run_all.sh [DIR]          # default DIR: target/bench-eqfa
#
# Writes DIR/single/ and DIR/cards/ (manifest.json, tables, reports, peers_sweep.json, score.md).
# AEROSID: the command (default target/debug/aerosid, built optimised: `nice cargo build -p aerosid
# --bin aerosid --profile test` — the dev profile leaves the workspace crates unoptimised, many times
# slower here);
# PY: a Python with pysindy 2.1.0 and sysidentpy 0.9.0 (default target/bench-venv/bin/python:
# `python3 -m venv target/bench-venv && target/bench-venv/bin/python -m pip install pysindy==2.1.0
# sysidentpy==0.9.0`); JOBS: the peers' parallel processes (default 2). Method: docs/benchmarks.md,
# "Peers at an equal false-alarm rate".
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."

DIR="${1:-target/bench-eqfa}"
AEROSID="${AEROSID:-target/debug/aerosid}"
PY="${PY:-target/bench-venv/bin/python}"
JOBS="${JOBS:-2}"
if [ ! -x "$AEROSID" ]; then
    echo "run_all.sh: $AEROSID not found: build it with \`nice cargo build -p aerosid --bin aerosid --profile test\` or set AEROSID" >&2
    exit 1
fi
if ! "$PY" -c 'import pysindy, sysidentpy' 2>/dev/null; then
    echo "run_all.sh: $PY lacks pysindy or sysidentpy: python3 -m venv target/bench-venv &&" \
        "target/bench-venv/bin/python -m pip install pysindy==2.1.0 sysidentpy==0.9.0 (or set PY)" >&2
    exit 1
fi
mkdir -p "$DIR"
start=$SECONDS
nice "$AEROSID" gaps-bench --clean 20 --out "$DIR/single"
nice "$AEROSID" gaps-bench --cards 3 --card-clean 20 --out "$DIR/cards"
for s in single cards; do
    # the sweeps, and beside them each peer's library default (STLSQ 0.1, FROLS by AIC) and BIC
    nice "$PY" scripts/bench/peers.py "$DIR/$s/manifest.json" -o "$DIR/$s/peers_sweep.json" \
        --sweep all --stlsq 0.1 --frols aic,bic --jobs "$JOBS"
    "$PY" scripts/bench/score.py "$DIR/$s/manifest.json" "$DIR/$s/peers_sweep.json" -o "$DIR/$s/score.md" >/dev/null
done
echo "run_all.sh: $DIR/single/score.md and $DIR/cards/score.md in $((SECONDS - start)) s"
