//! Puts the workspace's `memory.x` on the linker search path (knurling app-template style).
//!
//! cortex-m-rt's `link.x` does `INCLUDE memory.x`; the file lives once, at the workspace root, and is
//! copied into `OUT_DIR` so the link does not depend on the linker's working directory. Only the
//! firmware target needs it: on the host the binary is a stub and nothing is copied.

use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=build.rs");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }

    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory_x = manifest_dir.join("../memory.x");
    fs::copy(&memory_x, out_dir.join("memory.x"))
        .unwrap_or_else(|e| panic!("cannot copy {} into OUT_DIR: {e}", memory_x.display()));
    println!("cargo:rustc-link-search={}", out_dir.display());
}
