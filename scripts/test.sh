#!/usr/bin/env bash
# Runs all of the project's checks and tests, in the order CI runs them (.ci/run execs this file):
# tools (QEMU, defmt-print), formatting, host clippy, firmware clippy, the core built for the MCU,
# host tests (among them the firmware replayed under QEMU, with and without injected faults), the
# main job, the docs' generated tables against the tool, the HTML reports in headless Chromium, the
# firmware release build, its panic audit, its static stack bound and its size, then a short run of
# the core fuzz targets. Stops at the first failure.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

readonly THUMB=thumbv7em-none-eabihf
readonly FW_ELF="${CARGO_TARGET_DIR:-target}/$THUMB/release/aerosid-firmware"
# The host tool as `cargo test` builds it (the test profile: opt-level 3, with debug assertions and
# overflow checks). The main job and the firmware checks run this binary: building the release
# profile as well (fat LTO, one codegen unit, every dependency again) took 4 min 22 s of CI for the
# same code; the README's `cargo run --release …` commands build that profile for users.
readonly AEROSID="${CARGO_TARGET_DIR:-target}/debug/aerosid"

START=$SECONDS
LAST=$SECONDS
# step TITLE: prints the time the previous step took and the total so far, then the title.
step() {
    printf '\n(%d s; %d s in all)\n==> %s\n' "$((SECONDS - LAST))" "$((SECONDS - START))" "$*"
    LAST=$SECONDS
}

step "toolchain: $THUMB target, clippy, rustfmt, llvm-tools (idempotent)"
rustup target add "$THUMB"
rustup component add clippy rustfmt llvm-tools

step "QEMU and defmt-print for the firmware replay test (installed if missing)"
if ! command -v qemu-system-arm >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-system-arm
    else
        sudo apt-get update -qq && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-system-arm
    fi
fi
qemu-system-arm --version | head -1
if ! command -v defmt-print >/dev/null 2>&1; then
    # A debug build (it decodes a few kilobytes of log per run): 40 s less than an optimised one.
    cargo install defmt-print --locked --debug
fi

step "format: cargo fmt --all -- --check (and the fuzz workspace)"
cargo fmt --all -- --check
cargo fmt --manifest-path fuzz/Cargo.toml --all -- --check

step "fuzz crate clippy (its own workspace; the core targets, as CI fuzzes them): cargo clippy --manifest-path fuzz/Cargo.toml --no-default-features --bins -- -D warnings"
cargo clippy --manifest-path fuzz/Cargo.toml --no-default-features --bins -- -D warnings

step "host clippy: cargo clippy --workspace --all-targets -- -D warnings"
cargo clippy --workspace --all-targets -- -D warnings

step "firmware clippy: cargo fw-clippy (flight computer), and with the QEMU board"
cargo fw-clippy
cargo clippy -p aerosid-firmware --target "$THUMB" --release --features qemu -- -D warnings

step "core for the MCU (no std, no heap): cargo clippy -p aerosid-core --target $THUMB -- -D warnings"
cargo clippy -p aerosid-core --target "$THUMB" -- -D warnings

step "core docs (broken links are errors): cargo doc -p aerosid-core --no-deps"
RUSTDOCFLAGS="-D warnings" cargo doc -p aerosid-core --no-deps

step "host tests: cargo test --workspace"
cargo test --workspace

step "main job (README's \`aerosid run\`, the test-profile build): $AEROSID run --out target/main-job"
if [ ! -x "$AEROSID" ]; then
    echo "error: $AEROSID missing: \`cargo test --workspace\` builds it for the integration tests" >&2
    exit 1
fi
# Its printout is kept for the docs check below (which would otherwise fly the 180 s flight again).
"$AEROSID" run --out target/main-job | tee target/main-job.txt

step "docs tables current (docs/conventions.md): AEROSID=$AEROSID bash scripts/docs-tables.sh --check --main-job-output target/main-job.txt"
# The result tables in the docs are generated from this tool (the main job above, `aerosid gaps` on
# the vendored flights: a few seconds); a change in the analysis that leaves them stale fails here
# with the diff. `bash scripts/docs-tables.sh` regenerates them.
env AEROSID="$AEROSID" bash scripts/docs-tables.sh --check --main-job-output target/main-job.txt

step "HTML reports in headless Chromium (docs/reports.md): scripts/check-html.py on \`aerosid gaps\` pages"
# Chromium (Debian's package) installed if missing, as QEMU above. Two pages: the HFB-320 flight-test
# data (10 Hz, the low-rate output-error path) and a simulated flight with a named cause; each must render every figure
# written beside it inline, with no console error and a screenshot that is not blank.
if ! command -v chromium >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium
    else
        sudo apt-get update -qq && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium
    fi
fi
html_dir=target/html-check
rm -rf "$html_dir"
"$AEROSID" gaps --data tool/data/flight/hfb320_1_10.asc --with tool/data/maps/hfb320.map --out "$html_dir/hfb320" >/dev/null
"$AEROSID" gaps --simulate alpha-dot --seed 1 --out "$html_dir/alpha-dot" >/dev/null
python3 scripts/check-html.py --figures-beside --expect-id verdict --expect-id coefficients \
    --shots "$html_dir/shots" "$html_dir/hfb320/report.html" "$html_dir/alpha-dot/report.html"

step "firmware release build: cargo fw-build"
cargo fw-build

step "panic audit of the release firmware: aerosid panic-audit $FW_ELF firmware/panic-allow.txt"
"$AEROSID" panic-audit "$FW_ELF" firmware/panic-allow.txt

step "static stack bound and RAM of the release firmware: aerosid stack-bound $FW_ELF firmware/stack-bound.txt --ram-budget 16384"
# The RAM goal itself, 16 384 B (measured 15 440 B: 9 344 static + 6 096 stack; BENCHMARKS.md
# "Firmware size"): a change that breaks the goal fails here.
"$AEROSID" stack-bound "$FW_ELF" firmware/stack-bound.txt --ram-budget 16384

step "firmware size ($FW_ELF)"
size_tool=""
if command -v rust-size >/dev/null 2>&1; then
    # cargo-binutils is installed: its `rust-size` is what `cargo size` runs, here on the ELF just built
    # (a binary named cargo-size alone may be an unrelated crate).
    size_tool="rust-size"
else
    rustup component add llvm-tools >/dev/null 2>&1 || true
    host_triple="$(rustc -vV | sed -n 's/^host: //p')"
    candidate="$(rustc --print sysroot)/lib/rustlib/$host_triple/bin/llvm-size"
    if [ -x "$candidate" ]; then
        size_tool="$candidate"
    fi
fi
if [ -n "$size_tool" ]; then
    sizes="$("$size_tool" "$FW_ELF")"
    printf '%s\n' "$sizes"
    # The flash budget is the 128 KiB STM32F4 parts (docs/performance.md): asserted, as the size of
    # a given build is deterministic.
    printf '%s\n' "$sizes" | awk -v budget=131072 'NR == 2 {
        printf "flash (text + data): %d of 1048576 bytes (budget %d); RAM (data + bss): %d of 131072 bytes\n", $1 + $2, budget, $2 + $3
        if ($1 + $2 > budget) { printf "flash over the %d B budget by %d B\n", budget, $1 + $2 - budget; exit 1 }
    }'
else
    echo "no llvm-size (cargo-binutils or rustup's llvm-tools): the flash budget cannot be checked" >&2
    exit 1
fi

step "Python package (docs/python.md): bash scripts/python-tests.sh (the wheel built and installed in target/venv, pytest, the Dask batch)"
bash scripts/python-tests.sh

step "fuzzing (docs/reliability.md): the core libFuzzer targets of fuzz/ for ${FUZZ_SECONDS:-6} s each from their seeds"
# Its own workspace and target directory (fuzz/target-ours); stable Rust, no cargo-fuzz needed
# (scripts/fuzz.sh says how the build matches `cargo fuzz build -s none -a`, and why the reader
# targets run as a host test here). A crash fails CI and leaves the input in fuzz/artifacts/.
bash scripts/fuzz.sh ci "${FUZZ_SECONDS:-6}"

step "all checks passed"
