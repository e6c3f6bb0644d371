//! Progress of long sweeps, given to a Python callable `callback(done,
//! total, what)`. The library asks the process's one progress factory for a
//! bar ([`dexcut::progress::set_progress`]); this module installs a factory
//! that hands each bar the callable of the calling thread ([`Installed`]),
//! so runs in several threads each report to their own.

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use pyo3::prelude::*;

thread_local! {
    /// The callable of the run in progress on this thread.
    static CALLBACK: RefCell<Option<Arc<Py<PyAny>>>> = const { RefCell::new(None) };
}

/// The callable of this thread's run, while it lives.
pub struct Installed;

impl Installed {
    /// Give `callback` the progress of the runs of this thread until dropped.
    pub fn new(callback: Option<Py<PyAny>>) -> Installed {
        CALLBACK.with(|c| *c.borrow_mut() = callback.map(Arc::new));
        Installed
    }
}

impl Drop for Installed {
    fn drop(&mut self) {
        CALLBACK.with(|c| *c.borrow_mut() = None);
    }
}

/// A bar reporting to a Python callable: at most about 200 calls per bar.
struct Bar {
    callback: Arc<Py<PyAny>>,
    total: u64,
    what: String,
    step: u64,
    next: AtomicU64,
}

impl Bar {
    fn call(&self, done: u64) {
        Python::attach(|py| {
            if let Err(e) = self
                .callback
                .call1(py, (done, self.total, self.what.as_str()))
            {
                // A failing callback is told once and the run goes on.
                e.print(py);
            }
        });
    }
}

impl dexcut::progress::Progress for Bar {
    fn set_position(&self, done: u64) {
        let next = self.next.load(Ordering::Relaxed);
        if done >= next || done >= self.total {
            self.next.store(done + self.step, Ordering::Relaxed);
            self.call(done);
        }
    }

    fn finish_and_clear(&self) {
        self.call(self.total);
    }
}

struct Silent;

impl dexcut::progress::Progress for Silent {
    fn set_position(&self, _done: u64) {}
    fn finish_and_clear(&self) {}
}

fn bar(total: u64, what: &str) -> Box<dyn dexcut::progress::Progress> {
    match CALLBACK.with(|c| c.borrow().clone()) {
        Some(callback) => Box::new(Bar {
            callback,
            total,
            what: what.to_string(),
            step: (total / 200).max(1),
            next: AtomicU64::new(0),
        }),
        None => Box::new(Silent),
    }
}

/// Install the factory (once per process).
pub fn install() {
    dexcut::progress::set_progress(bar);
}
