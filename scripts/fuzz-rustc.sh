#!/usr/bin/env bash
# RUSTC_WRAPPER for `FUZZ_INSTRUMENT=ours bash scripts/fuzz.sh …`: adds the libFuzzer
# instrumentation in $FUZZ_RUSTC_FLAGS to the project's own crates, the ULog parser and the fuzz
# targets only; every other crate is compiled as cargo asked. Cargo does not see these flags, so
# after changing them delete fuzz/target-ours/.
rustc="$1"
shift
crate=""
prev=""
for a in "$@"; do
    if [ "$prev" = "--crate-name" ]; then
        crate="$a"
        break
    fi
    prev="$a"
done
case "$crate" in
    aerosid_core | aerosid_read | aerosid_sim | aerosid_fuzz | px4_ulog | gtls | pipeline | drivers | mavlink | read_*)
        # shellcheck disable=SC2086 # the flags are a space-separated list on purpose
        exec "$rustc" "$@" $FUZZ_RUSTC_FLAGS
        ;;
    *) exec "$rustc" "$@" ;;
esac
