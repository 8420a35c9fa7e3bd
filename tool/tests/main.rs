//! The tests of the `aerosid` command and of the analyses it runs on vendored data, one module per
//! file, built as one test binary. They live in this package because only its own tests are given
//! the binary's path (`CARGO_BIN_EXE_aerosid`).

mod batch;
mod clean_cards;
mod cli;
mod corrupt_logs;
mod delay_rival;
mod exit_codes;
mod families;
mod flow_angles;
mod low_rate;
mod origin;
mod pooled;
mod predict;
mod real_logs;
mod report_coherence;
mod scatter;
mod workflow;
