//! The log-reader fuzz targets in CI: the very invariant checks of `fuzz/src/readers.rs`
//! (included below, not copied) over each target's committed seed corpus and seeded mutations of
//! it. CI runs the core fuzz targets under libFuzzer (`scripts/fuzz.sh ci`) but not these: their
//! instrumented build pulls in all of the `aerosid` tool's dependencies (minutes; `scripts/fuzz.sh`
//! says how many). This test has no coverage guidance; the libFuzzer long runs behind the README's
//! figures do (`bash scripts/fuzz.sh long SECONDS read_log …`). Any panic — a reader's or a failed
//! invariant's — fails the test and prints the input's seed, file and mutation number.

#[allow(dead_code)]
#[path = "../../fuzz/src/readers.rs"]
mod readers;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Mutations per seed file (with the seed file itself first).
const MUTATIONS: usize = 20_000;

/// Bytes a mutation likes to put in: separators, signs, digits, exponents, NaN/inf spellings'
/// letters, line ends, and ULog's message-type letters and 0/0xFF.
const INTERESTING: &[u8] = b",;\t \n\r-+.0123456789eEnNaAiIfF%#=[]:\x00\xffABDFILMPQRSO";

/// One seeded mutation of `seed` (a few edits of the kinds libFuzzer's default mutators make).
fn mutate(seed: &[u8], others: &[Vec<u8>], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut d = seed.to_vec();
    for _ in 0..rng.random_range(1..8) {
        let len = d.len();
        match rng.random_range(0..9) {
            0 if len > 0 => {
                let i = rng.random_range(0..len);
                d[i] ^= 1 << rng.random_range(0..8);
            }
            1 if len > 0 => {
                let i = rng.random_range(0..len);
                d[i] = INTERESTING[rng.random_range(0..INTERESTING.len())];
            }
            2 => {
                let i = rng.random_range(0..=len);
                let b = INTERESTING[rng.random_range(0..INTERESTING.len())];
                d.insert(i, b);
            }
            3 if len > 0 => {
                let i = rng.random_range(0..len);
                let n = rng.random_range(1..=(len - i).min(64));
                d.drain(i..i + n);
            }
            4 if len > 0 => {
                // duplicate a chunk (repeated lines, repeated messages)
                let i = rng.random_range(0..len);
                let n = rng.random_range(1..=(len - i).min(256));
                let chunk: Vec<u8> = d[i..i + n].to_vec();
                let at = rng.random_range(0..=d.len());
                d.splice(at..at, chunk);
            }
            5 if len > 0 => d.truncate(rng.random_range(0..len)),
            6 if !others.is_empty() => {
                // splice with another seed of the target (libFuzzer's cross-over)
                let o = &others[rng.random_range(0..others.len())];
                if !o.is_empty() {
                    let i = rng.random_range(0..o.len());
                    let at = rng.random_range(0..=d.len());
                    d.splice(at..at, o[i..].iter().copied().take(512));
                }
            }
            7 if len >= 4 => {
                // an integer field set to an extreme (little-endian u32 in binary logs)
                let i = rng.random_range(0..len - 3);
                let v = [0u32, 1, 0x7FFF_FFFF, 0xFFFF_FFFF, 0x8000_0000][rng.random_range(0..5)];
                d[i..i + 4].copy_from_slice(&v.to_le_bytes());
            }
            _ => {
                // a long number, or a huge exponent
                let i = rng.random_range(0..=len);
                let s: &[u8] =
                    [&b"1e308"[..], b"-1e-320", b"99999999999999999999", b"nan", b"-inf"][rng.random_range(0..5)];
                d.splice(i..i, s.iter().copied());
            }
        }
    }
    d
}

fn seeds(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds").join(target);
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| {
            let p = e.path();
            (
                p.file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
            )
        })
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no seeds in {}", dir.display());
    out
}

fn fuzz(target: &str, run: fn(&[u8]), seed: u64) {
    fuzz_files(target, seeds(target), run, seed, MUTATIONS);
}

fn fuzz_files(target: &str, files: Vec<(String, Vec<u8>)>, run: fn(&[u8]), seed: u64, mutations: usize) {
    let others: Vec<Vec<u8>> = files.iter().map(|(_, d)| d.clone()).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut inputs = 0usize;
    for (name, data) in &files {
        for m in 0..=mutations {
            let input = if m == 0 {
                data.clone()
            } else {
                mutate(data, &others, &mut rng)
            };
            inputs += 1;
            if let Err(e) = catch_unwind(AssertUnwindSafe(|| run(&input))) {
                let dump = std::env::temp_dir().join(format!("aerosid-{target}-crash-{seed}-{m}"));
                let _ = std::fs::write(&dump, &input);
                let msg = e
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                panic!(
                    "{target}: seed file {name}, mutation {m} (rng seed {seed}) failed: {msg}; input in {}",
                    dump.display()
                );
            }
        }
    }
    println!("{target}: {inputs} inputs from {} seed files", files.len());
}

#[test]
fn read_log() {
    fuzz("read_log", readers::read_log::run, 1);
}

#[test]
fn read_project_csv() {
    fuzz("read_project_csv", readers::read_project_csv::run, 2);
}

#[test]
fn read_aircraft() {
    fuzz("read_aircraft", readers::read_aircraft::run, 3);
}

#[test]
fn read_colmap_ascii() {
    fuzz("read_colmap_ascii", readers::read_colmap_ascii::run, 4);
}

#[test]
fn read_ulog() {
    fuzz("read_ulog", readers::read_ulog::run, 5);
}

#[test]
fn read_dataflash() {
    // Two ArduPlane logs' first bytes; each mutation parses the whole prefix, so fewer mutations.
    fuzz_files(
        "read_dataflash",
        seeds("read_dataflash"),
        readers::read_dataflash::run,
        6,
        3_000,
    );
}

#[test]
fn read_mat() {
    // The Twin Otter's `.mat` (compressed level-5 variables); each parse inflates it, so fewer
    // mutations.
    fuzz_files("read_mat", seeds("read_mat"), readers::read_mat::run, 7, 300);
}
