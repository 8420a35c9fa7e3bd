//! Progress bars of the long commands (`long-run`, `gaps-bench`; the Monte Carlo has its own):
//! indicatif on stderr, drawn only when stderr is a terminal, so piped or redirected output and
//! CI logs get no bar characters.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A bar of `len` steps labelled `what` (e.g. "flights"), or a hidden one when stderr is not a
/// terminal ([`ProgressBar::is_hidden`] tells which, for a caller that prints lines instead).
pub fn bar(len: u64, what: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    let template = format!("{{bar:40}} {{pos}}/{{len}} {what}, {{elapsed}} elapsed, eta {{eta}}");
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style);
    }
    bar
}
