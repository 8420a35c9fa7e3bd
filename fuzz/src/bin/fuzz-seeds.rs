//! Writes the seed corpus to `fuzz/seeds/<target>/` (see `aerosid_fuzz::seeds`), replacing what is
//! there. Run from anywhere: `cargo run --release --manifest-path fuzz/Cargo.toml --features seeds
//! --bin fuzz-seeds`.

use std::path::Path;

fn main() -> std::process::ExitCode {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("seeds");
    let seeds = aerosid_fuzz::seeds::all();
    let mut targets: Vec<&str> = seeds.iter().map(|(t, _, _)| *t).collect();
    targets.dedup();
    for t in &targets {
        let dir = root.join(t);
        let _ = std::fs::remove_dir_all(&dir);
        if let Err(e) = std::fs::create_dir_all(&dir) {
            eprintln!("fuzz-seeds: {}: {e}", dir.display());
            return std::process::ExitCode::FAILURE;
        }
    }
    let mut bytes = 0;
    for (t, name, data) in &seeds {
        let path = root.join(t).join(name);
        if let Err(e) = std::fs::write(&path, data) {
            eprintln!("fuzz-seeds: {}: {e}", path.display());
            return std::process::ExitCode::FAILURE;
        }
        bytes += data.len();
    }
    println!(
        "fuzz-seeds: {} files, {bytes} bytes, in {}",
        seeds.len(),
        root.display()
    );
    std::process::ExitCode::SUCCESS
}
