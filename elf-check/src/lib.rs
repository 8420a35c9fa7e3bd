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
#![forbid(unsafe_code)]

pub mod panic_audit;
pub mod stack_bound;
