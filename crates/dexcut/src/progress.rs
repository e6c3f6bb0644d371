//! Progress of long sweeps, reported to whatever the program installs with
//! [`set_progress`] (the dexcut binary draws bars on a terminal); silent by default.

use std::sync::OnceLock;

/// Receives the progress of one long computation.
pub trait Progress: Send + Sync {
    /// `done` items of the work are finished.
    fn set_position(&self, done: u64);
    /// The work has ended: remove any display.
    fn finish_and_clear(&self);
}

/// Makes a [`Progress`] for `len` items of work named `what`.
pub type ProgressFactory = fn(len: u64, what: &str) -> Box<dyn Progress>;

static FACTORY: OnceLock<ProgressFactory> = OnceLock::new();

/// Install the progress display of this process. The first call wins; later
/// ones are ignored.
pub fn set_progress(factory: ProgressFactory) {
    let _ = FACTORY.set(factory);
}

struct Silent;

impl Progress for Silent {
    fn set_position(&self, _done: u64) {}
    fn finish_and_clear(&self) {}
}

/// A progress display for `len` items: the installed one, or none.
pub fn bar(len: u64, what: &str) -> Box<dyn Progress> {
    match FACTORY.get() {
        Some(make) => make(len, what),
        None => Box::new(Silent),
    }
}
