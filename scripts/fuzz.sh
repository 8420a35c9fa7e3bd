#!/usr/bin/env bash
# Builds and runs the libFuzzer targets of fuzz/ on stable Rust, without cargo-fuzz.
#
#   bash scripts/fuzz.sh build            build every target (instrumented, release, debug assertions)
#   bash scripts/fuzz.sh ci [SECONDS]     build the core targets (gtls pipeline drivers mavlink), run
#                                         each SECONDS (default 8) from the seeds (what CI runs)
#   bash scripts/fuzz.sh long SECONDS [TARGET…]
#                                         run each (or the named) target SECONDS; prints executions,
#                                         coverage and corpus size per target (the README's figures)
#
# CI fuzzes the core targets only: the seven log-reader targets (read_*) link the reading crate
# (aerosid-read, with px4-ulog, matfile and serde); built with the whole aerosid tool they took
# 5 min 20 s instrumented (3 min 20 s CPU, a loaded 2-core machine while it also linked faer)
# against 1 min 20 s for the core targets: beyond CI's budget.
# In CI the reader targets' invariants run instead over their seed corpus and seeded mutations of
# it as a host test (host-tests/tests/fuzz_readers.rs, no coverage guidance); `long` fuzzes them.
#
# The build applies exactly the instrumentation that `cargo fuzz build -s none -a` (cargo-fuzz 0.13.2)
# passes in RUSTFLAGS — sanitizer-coverage with inline 8-bit counters, PC table, comparison tracing
# and stack depth, `--cfg fuzzing`, no branch folding, debug assertions (so integer overflow panics),
# one codegen unit, release — and libfuzzer-sys supplies libFuzzer, so the binaries are what
# `cargo fuzz run TARGET -s none -a` would run. No sanitizer: the code under test has no `unsafe`
# (the core forbids it), so AddressSanitizer (nightly-only `-Zsanitizer=address`; on stable only
# through RUSTC_BOOTSTRAP=1) would watch nalgebra's and libFuzzer's internals only.
#
# FUZZ_INSTRUMENT selects what is instrumented:
#   all  — every crate, as cargo-fuzz does (fuzz/target/); used for the README's long runs;
#   ours — (default) only aerosid-core, aerosid-read, aerosid-sim, px4-ulog and the fuzz crate get the flags above
#          (through scripts/fuzz-rustc.sh as RUSTC_WRAPPER, in fuzz/target-ours/); the other
#          dependencies are plain release builds. Generic code (nalgebra's matrices) is instantiated,
#          hence instrumented, in our crates either way; what is lost is coverage guidance inside
#          the other dependencies (serde, which the targets barely call; matfile and nom under
#          read_mat) — and the build is minutes shorter (CI).
#
# Corpora: libFuzzer reads fuzz/seeds/TARGET (committed) and writes what it finds to
# fuzz/corpus/TARGET (git-ignored); crashes go to fuzz/artifacts/TARGET/ and fail the run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../fuzz"

readonly CORE_TARGETS=(gtls pipeline drivers mavlink)
readonly READER_TARGETS=(read_log read_project_csv read_aircraft read_colmap_ascii read_ulog read_dataflash read_mat)
readonly TARGETS=("${CORE_TARGETS[@]}" "${READER_TARGETS[@]}")
readonly TRIPLE="$(rustc -vV | sed -n 's/^host: //p')"
readonly MODE="${FUZZ_INSTRUMENT:-ours}"
readonly FLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing \
-Cllvm-args=-simplifycfg-branch-fold-threshold=0 -Cllvm-args=-sanitizer-coverage-stack-depth \
-Cdebug-assertions -Ccodegen-units=1"
case "$MODE" in
    all) readonly TARGET_DIR=target ;;
    ours) readonly TARGET_DIR=target-ours ;;
    *) echo "FUZZ_INSTRUMENT must be all or ours" >&2; exit 2 ;;
esac
readonly BIN_DIR="$TARGET_DIR/$TRIPLE/release"

# build [cargo flags…]: the instrumented targets (all of them, or e.g. `--no-default-features`).
build() {
    if [ "$MODE" = all ]; then
        RUSTFLAGS="$FLAGS" cargo build --locked --release --target "$TRIPLE" --target-dir "$TARGET_DIR" --bins "$@"
    else
        FUZZ_RUSTC_FLAGS="$FLAGS" RUSTC_WRAPPER="$PWD/../scripts/fuzz-rustc.sh" \
            cargo build --locked --release --target "$TRIPLE" --target-dir "$TARGET_DIR" --bins "$@"
    fi
}

# run TARGET SECONDS: libFuzzer for SECONDS, single process; prints its final statistics line.
run() {
    local t="$1" secs="$2"
    mkdir -p "corpus/$t" "artifacts/$t"
    local log
    log="$(mktemp)"
    if ! "$BIN_DIR/$t" -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="artifacts/$t/" "corpus/$t" "seeds/$t" >"$log" 2>&1; then
        tail -n 60 "$log"
        rm -f "$log"
        echo "fuzz: target $t FAILED (input in fuzz/artifacts/$t/)"
        return 1
    fi
    local execs cov ft units
    execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")"
    cov="$(grep -Eo 'cov: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)"
    ft="$(grep -Eo 'ft: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)"
    units="$(find "corpus/$t" -type f | wc -l)"
    printf 'fuzz: %-18s %5ss  %10s execs  cov %6s  ft %6s  corpus %5s\n' "$t" "$secs" "$execs" "$cov" "$ft" "$units"
    rm -f "$log"
}

case "${1:-}" in
    build) build ;;
    ci)
        secs="${2:-8}"
        build --no-default-features
        failed=0
        for t in "${CORE_TARGETS[@]}"; do run "$t" "$secs" || failed=1; done
        exit "$failed"
        ;;
    long)
        secs="${2:?seconds per target}"
        shift 2
        list=("$@")
        [ ${#list[@]} -eq 0 ] && list=("${TARGETS[@]}")
        build
        failed=0
        for t in "${list[@]}"; do run "$t" "$secs" || failed=1; done
        exit "$failed"
        ;;
    *)
        sed -n '2,9p' "$0"
        exit 2
        ;;
esac
