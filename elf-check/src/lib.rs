//! # aerosid-elf-check
//!
//! Checks of the linked firmware image, read from its machine code: no panic path outside a
//! justified allow-list, and a static bound on the stack.
//!
//! * [`panic_audit`] — every call site of the panic machinery left in the release image.
//! * [`stack_bound`] — the worst-case stack depth over the call graph, and RAM against a budget.
//!
//! It depends on nothing of aerosid (both read `llvm-objdump` output of an ELF), so any crate can
//! use it; the `aerosid` command's `panic-audit` and `stack-bound` subcommands call it, which keeps
//! one binary for the user and for CI (`scripts/test.sh`).
//!
//! ```
//! use aerosid_elf_check::panic_audit::{audit, parse_allowlist};
//! // An `llvm-objdump -d -C` listing: `app::task` branches to a panic entry.
//! let disassembly = "\
//! 08000100 <app::task>:
//!  8000100:      \tbl\t0x8000500 <core::panicking::panic_bounds_check> @ imm = #0x3fc
//!
//! 08000500 <core::panicking::panic_bounds_check>:
//!  8000500:      \tbx\tlr
//! ";
//! let allowed = parse_allowlist("app::task | panic_bounds_check | the index is bounded by the loop")?;
//! let report = audit(disassembly, allowed);
//! assert!(report.uncovered().is_empty(), "{}", report.report());
//! # Ok::<(), String>(())
//! ```
#![forbid(unsafe_code)]

pub mod panic_audit;
pub mod stack_bound;
