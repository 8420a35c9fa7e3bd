//! Panic paths in a linked firmware image: every call site of Rust's panic machinery
//! that survived the release build, checked against a committed list of justified exceptions.
//!
//! ## Why a link-time audit and not the "undefined panic handler" trick
//! The usual proof replaces the panic handler by a call to a symbol defined nowhere, so the link
//! fails if any panic path is left. For this firmware that link cannot succeed, for reasons no
//! code of ours can remove: every `async fn` state machine (the RTIC 2 tasks, `rtic-sync`'s
//! channel futures, `rtic-time`'s delays) carries a compiler-generated "`async fn` resumed after
//! completion" panic, and `defmt-rtt`, `rtic-sync` and `rtic-time` keep guard panics (a logger
//! taken re-entrantly, a channel made twice, a timer queue used before it is started). So the audit
//! reads the image instead: it disassembles it (`llvm-objdump -d`, from rustup's `llvm-tools`),
//! finds the panic entry points (`core::panicking::*`, the slice and `Option`/`Result` failure
//! functions, the panic handler), lists every function that branches to one, and requires each
//! to be covered by an entry of the allow-list, whose every line says why the path cannot be taken
//! — or says that it is not shown to be unreachable. A new panic path anywhere else fails.
//!
//! ## The allow-list
//! One exception per line: `function substring | entry substring | reason`; `#` starts a comment.
//! A site is covered when its (demangled, hash-stripped) function name contains the first field
//! and the entry point's name the second. Entries that cover nothing are reported (stale).
//!
//! Granularity: functions after inlining, not source lines (which move with every edit): a new
//! panic site inside an already listed function is not caught. The per-site counts are printed so
//! that a change is visible in the CI log.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One function of the image that branches to a panic entry point.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Site {
    /// The calling function (demangled, without its hash).
    pub function: String,
    /// The panic entry point it branches to.
    pub entry: String,
    /// Branches from `function` to `entry`.
    pub count: usize,
}

/// An allow-list line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Allowed {
    /// Substring of the calling function.
    pub function: String,
    /// Substring of the entry point.
    pub entry: String,
    /// Why the path is not taken (or that it is not shown).
    pub reason: String,
}

/// The audit of one image.
#[derive(Debug, Clone, Default)]
pub struct Audit {
    /// Every site with the allow-list entry covering it (index into the list), if any.
    pub sites: Vec<(Site, Option<usize>)>,
    /// The allow-list.
    pub allowed: Vec<Allowed>,
}

impl Audit {
    /// Sites no allow-list entry covers.
    pub fn uncovered(&self) -> Vec<&Site> {
        self.sites.iter().filter(|(_, a)| a.is_none()).map(|(s, _)| s).collect()
    }

    /// Allow-list entries that cover no site.
    pub fn stale(&self) -> Vec<&Allowed> {
        self.allowed
            .iter()
            .enumerate()
            .filter(|(i, _)| !self.sites.iter().any(|(_, a)| *a == Some(*i)))
            .map(|(_, a)| a)
            .collect()
    }

    /// The audit as a table.
    pub fn report(&self) -> String {
        let mut out = String::new();
        let total: usize = self.sites.iter().map(|(s, _)| s.count).sum();
        out.push_str(&format!(
            "panic audit: {} branches to the panic machinery from {} functions\n",
            total,
            self.sites.len()
        ));
        for (s, a) in &self.sites {
            let why = match a {
                Some(i) => self.allowed[*i].reason.as_str(),
                None => "NOT ALLOWED: a new panic path",
            };
            out.push_str(&format!(
                "  {:3} × {:<28} in {}\n        {}\n",
                s.count, s.entry, s.function, why
            ));
        }
        for a in self.stale() {
            out.push_str(&format!(
                "  stale allow-list entry (covers nothing; remove it): {} | {}\n",
                a.function, a.entry
            ));
        }
        out
    }
}

/// Whether a function of the image is part of the panic machinery.
pub fn is_panic_entry(name: &str) -> bool {
    name.starts_with("core::panicking::")
        || name.ends_with("rust_begin_unwind")
        || (name.starts_with("core::") && (name.ends_with("_fail") || name.ends_with("_failed")))
        || (name.starts_with("core::") && name.contains("::panic_"))
}

/// Strips the legacy-mangling hash (`::h0123456789abcdef`).
fn strip_hash(name: &str) -> &str {
    match name.rfind("::h") {
        Some(at) if name.len() - at == 19 && name[at + 3..].bytes().all(|b| b.is_ascii_hexdigit()) => &name[..at],
        _ => name,
    }
}

/// The sites of a disassembly (`llvm-objdump -d -C` text).
pub fn sites(disassembly: &str) -> Vec<Site> {
    let header = |l: &str| -> Option<String> {
        let l = l.trim_end();
        let rest = l.strip_suffix(">:")?;
        let (addr, name) = rest.split_once(" <")?;
        addr.bytes().all(|b| b.is_ascii_hexdigit()).then(|| name.to_string())
    };
    let entries: std::collections::BTreeSet<String> = disassembly
        .lines()
        .filter_map(header)
        .filter(|n| is_panic_entry(strip_hash(n)))
        .collect();
    let mut counts: BTreeMap<(String, String), usize> = BTreeMap::new();
    let mut current: Option<String> = None;
    for l in disassembly.lines() {
        if let Some(name) = header(l) {
            current = (!entries.contains(&name)).then(|| strip_hash(&name).to_string());
            continue;
        }
        let Some(caller) = &current else {
            continue;
        };
        // `  8001234:  bl  0x8005678 <core::panicking::panic_fmt> @ imm = …`: a branch (b, bl,
        // b.w, beq.w, cbz, …) whose target objdump names.
        let mut words = l.split_whitespace();
        let Some(op) = words.nth(1) else {
            continue;
        };
        if !(op.starts_with('b') || op.starts_with("cb")) {
            continue;
        }
        let Some(at) = l.find(" <") else {
            continue;
        };
        let target = &l[at + 2..];
        let Some(end) = target.find('>') else {
            continue;
        };
        let target = target[..end].split('+').next().unwrap_or("");
        if entries.contains(target) {
            *counts
                .entry((caller.clone(), strip_hash(target).to_string()))
                .or_default() += 1;
        }
    }
    counts
        .into_iter()
        .map(|((function, entry), count)| Site { function, entry, count })
        .collect()
}

/// Parses an allow-list (module doc).
pub fn parse_allowlist(text: &str) -> Result<Vec<Allowed>, String> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let parts: Vec<&str> = line.splitn(3, " | ").map(str::trim).collect();
        match parts.as_slice() {
            [f, e, r] if !f.is_empty() && !e.is_empty() && !r.is_empty() => out.push(Allowed {
                function: f.to_string(),
                entry: e.to_string(),
                reason: r.to_string(),
            }),
            _ => {
                return Err(format!(
                    "allow-list line {}: `function | entry | reason` expected",
                    n + 1
                ))
            }
        }
    }
    Ok(out)
}

/// Audits a disassembly against an allow-list.
pub fn audit(disassembly: &str, allowed: Vec<Allowed>) -> Audit {
    let sites = sites(disassembly)
        .into_iter()
        .map(|s| {
            let a = allowed
                .iter()
                .position(|a| s.function.contains(&a.function) && s.entry.contains(&a.entry));
            (s, a)
        })
        .collect();
    Audit { sites, allowed }
}

/// `llvm-objdump`: `$AEROSID_OBJDUMP`, rustup's `llvm-tools`, or the one on `PATH`.
pub fn objdump() -> PathBuf {
    if let Some(p) = std::env::var_os("AEROSID_OBJDUMP") {
        return PathBuf::from(p);
    }
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = |args: &[&str]| {
        Command::new(&rustc)
            .args(args)
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    if let (Some(sysroot), Some(vv)) = (out(&["--print", "sysroot"]), out(&["-vV"])) {
        if let Some(host) = vv.lines().find_map(|l| l.strip_prefix("host: ")) {
            let p = Path::new(&sysroot)
                .join("lib/rustlib")
                .join(host)
                .join("bin/llvm-objdump");
            if p.exists() {
                return p;
            }
        }
    }
    PathBuf::from("llvm-objdump")
}

/// Disassembles `elf` and audits it against the allow-list file `allowlist`.
pub fn audit_elf(elf: &Path, allowlist: &Path) -> Result<Audit, String> {
    let text = std::fs::read_to_string(allowlist).map_err(|e| format!("{}: {e}", allowlist.display()))?;
    let allowed = parse_allowlist(&text)?;
    let tool = objdump();
    let out = Command::new(&tool)
        .args(["-d", "--no-show-raw-insn", "-C"])
        .arg(elf)
        .output()
        .map_err(|e| {
            format!(
                "{}: {e} (install: `rustup component add llvm-tools`, or set AEROSID_OBJDUMP)",
                tool.display()
            )
        })?;
    if !out.status.success() {
        return Err(format!(
            "{} {}: {}",
            tool.display(),
            elf.display(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(audit(&String::from_utf8_lossy(&out.stdout), allowed))
}

#[cfg(test)]
mod tests {
    use super::*;

    const DIS: &str = "\
08000100 <app::task::h0123456789abcdef>:
 8000100:      \tpush\t{r7, lr}
 8000102:      \tbl\t0x8000300 <core::panicking::panic_bounds_check> @ imm = #0x1fc
 8000106:      \tbeq.w\t0x8000300 <core::panicking::panic_bounds_check> @ imm = #0x1f8
 800010a:      \tbl\t0x8000200 <helper::h1111111111111111> @ imm = #0xf4
 800010e:      \tldr\tr0, [pc, #0x8]  @ 0x8000118 <core::panicking::panic_fmt>

08000200 <helper::h1111111111111111>:
 8000200:      \tb.w\t0x8000400 <core::slice::index::slice_index_fail+0x4> @ imm = #0x1fc

08000300 <core::panicking::panic_bounds_check>:
 8000300:      \tbl\t0x8000500 <core::panicking::panic_fmt> @ imm = #0x1fc

08000400 <core::slice::index::slice_index_fail>:
 8000400:      \tb\t0x8000400 <core::slice::index::slice_index_fail> @ imm = #-0x4

08000500 <core::panicking::panic_fmt>:
 8000500:      \tbx\tlr
";

    #[test]
    fn branches_to_panic_entries_are_sites_and_loads_and_internal_calls_are_not() {
        let s = sites(DIS);
        assert_eq!(
            s,
            vec![
                Site {
                    function: "app::task".into(),
                    entry: "core::panicking::panic_bounds_check".into(),
                    count: 2
                },
                Site {
                    function: "helper".into(),
                    entry: "core::slice::index::slice_index_fail".into(),
                    count: 1
                },
            ]
        );
    }

    #[test]
    fn the_allowlist_covers_by_substring_and_reports_new_and_stale_entries() {
        let allowed = parse_allowlist(
            "# comment\napp::task | panic_bounds_check | indices bounded\nnothing::here | panic_fmt | old\n",
        )
        .expect("list");
        let a = audit(DIS, allowed);
        assert_eq!(a.uncovered().len(), 1, "{}", a.report());
        assert_eq!(a.uncovered()[0].function, "helper");
        assert_eq!(a.stale().len(), 1);
        assert!(a.report().contains("NOT ALLOWED"));
        assert!(parse_allowlist("only | two").is_err());
    }
}
