//! The one progress bar style of `train` (episodes) and `sweep` (runs).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar of `len` `unit`s (`"episode"`, `"runs"`) with elapsed time, a message and the time
/// left; hidden with `--quiet` or when stderr is not a terminal (CI logs, pipes).
///
/// ```
/// let bar = host_trainer::run::progress::bar(10, "episode", true);
/// bar.set_position(3);
/// assert_eq!(bar.position(), 3);
/// ```
pub fn bar(len: u64, unit: &str, quiet: bool) -> ProgressBar {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
    }
    let bar = ProgressBar::new(len);
    let template =
        format!("{{elapsed_precise}} [{{bar:30}}] {unit} {{pos}}/{{len}}  {{msg}}  eta {{eta}}");
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}
