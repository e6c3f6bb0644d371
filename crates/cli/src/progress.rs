//! Progress bars on a terminal; silent in CI and when output is piped.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

struct Bar(ProgressBar);

impl dexcut::progress::Progress for Bar {
    fn set_position(&self, done: u64) {
        self.0.set_position(done);
    }

    fn finish_and_clear(&self) {
        self.0.finish_and_clear();
    }
}

/// A bar over `len` items, drawn only when stderr is a terminal and CI is not set.
pub fn bar(len: u64, what: &str) -> Box<dyn dexcut::progress::Progress> {
    let visible = std::io::stderr().is_terminal() && std::env::var_os("CI").is_none();
    let target = if visible {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let bar = ProgressBar::with_draw_target(Some(len), target);
    bar.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    Box::new(Bar(bar))
}
