//! [`Error`]: why a step of the library failed, by kind of failure, with the
//! error that caused it kept as its [`source`](std::error::Error::source).

use std::path::{Path, PathBuf};

/// A cause from another crate (TOML, CSV, JSON, a domain crate), kept whole.
pub type Source = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Why a step of the library API failed. Each variant is one kind of failure;
/// its message names the place (`FILE:LINE:COL`, the job key and its allowed
/// range, or the file) and [`source`](std::error::Error::source) gives the
/// error underneath, when there is one. The whole account, as the command line
/// prints it, is the message followed by each source's.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The job file or a key of it: TOML syntax at `job.toml:LINE:COL`, a key
    /// out of its allowed range, a missing section, a settings fragment.
    #[error("{message}")]
    Job {
        /// What is wrong, naming the file and line or the key.
        message: String,
        /// The TOML or domain error underneath.
        #[source]
        source: Option<Source>,
    },
    /// The G-code reader refused the program: each error at `FILE:LINE:COL`.
    #[error("{} error(s) in the program:\n{}", .diagnostics.len(), join(.diagnostics))]
    Program {
        /// Every error diagnostic of the reader.
        diagnostics: Vec<nc::Diagnostic>,
    },
    /// A text input (a tool-tip point list, measurements, servo samples) at
    /// `FILE:LINE:COLUMN`.
    #[error("{file}:{line}:{column}: {message}")]
    Input {
        /// The file, as named in messages.
        file: String,
        /// 1-based line.
        line: u64,
        /// 1-based column.
        column: u64,
        /// What is wrong there.
        message: String,
        /// The CSV or number-parsing error underneath.
        #[source]
        source: Option<Source>,
    },
    /// A stock or design mesh that cannot be read or is not a closed solid
    /// (the mesh crate's error names the file).
    #[error(transparent)]
    Mesh(#[from] mesh::MeshError),
    /// The motion could not be planned (the schedule crate's error).
    #[error(transparent)]
    Motion(#[from] schedule::ScheduleError),
    /// The stock or the sweep refused a parameter or a grid too large.
    #[error(transparent)]
    Stock(#[from] dexel::Error),
    /// An output (heat map, stock model, column grid) could not be made or written.
    #[error(transparent)]
    Export(#[from] export::Error),
    /// A file or folder could not be read, written or moved.
    #[error("{action} {}", .path.display())]
    Io {
        /// What was tried: "cannot read program", "cannot write", …
        action: String,
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The run would exceed a size bound: a file, a grid, the motion's samples
    /// or the memory it needs.
    #[error("{message}")]
    Limits {
        /// What would be too large and the bound.
        message: String,
        /// The domain error underneath.
        #[source]
        source: Option<Source>,
    },
    /// Something the given inputs cannot serve (`--actual-path` on a point
    /// list, `--sweep` with `--servo`, `arcs_as_lines` for optimize).
    #[error("{message}")]
    Request {
        /// What cannot be done and why.
        message: String,
    },
    /// The computation gave no result: planning, sweeping, re-feeding or the
    /// drive model failed, or a result is not finite.
    #[error("{message}")]
    Run {
        /// What failed.
        message: String,
        /// The domain error underneath.
        #[source]
        source: Option<Source>,
    },
    /// A results folder or file (summary.json, steps.csv, manifest.json,
    /// the column grid) is missing, of another version or invalid.
    #[error("{message}")]
    Results {
        /// What is wrong, naming the file.
        message: String,
        /// The JSON, CSV or number error underneath.
        #[source]
        source: Option<Source>,
    },
    /// Where an error of the kinds above happened.
    #[error("{context}")]
    Context {
        /// Where, or what was being done.
        context: String,
        /// The error.
        #[source]
        source: Box<Error>,
    },
}

fn join(diagnostics: &[nc::Diagnostic]) -> String {
    diagnostics
        .iter()
        .map(|d| d.to_string())
        .collect::<Vec<_>>()
        .join("\n")
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A job error with no cause underneath.
    pub(crate) fn job(message: impl Into<String>) -> Error {
        Error::Job {
            message: message.into(),
            source: None,
        }
    }

    /// A size bound exceeded.
    pub(crate) fn limits(message: impl Into<String>) -> Error {
        Error::Limits {
            message: message.into(),
            source: None,
        }
    }

    /// A request the inputs cannot serve.
    pub(crate) fn request(message: impl Into<String>) -> Error {
        Error::Request {
            message: message.into(),
        }
    }

    /// A computation with no result.
    pub(crate) fn run(message: impl Into<String>) -> Error {
        Error::Run {
            message: message.into(),
            source: None,
        }
    }

    /// An invalid results folder or file.
    pub(crate) fn results(message: impl Into<String>) -> Error {
        Error::Results {
            message: message.into(),
            source: None,
        }
    }

    /// A text input's fault at `file:line:column`.
    pub(crate) fn input(file: &str, line: u64, column: u64, message: impl Into<String>) -> Error {
        Error::Input {
            file: file.to_string(),
            line,
            column,
            message: message.into(),
            source: None,
        }
    }

    /// An I/O error on `path`.
    pub(crate) fn io(action: impl Into<String>, path: &Path, source: std::io::Error) -> Error {
        Error::Io {
            action: action.into(),
            path: path.to_path_buf(),
            source,
        }
    }

    /// This error with `context` before it: joined into the message of the
    /// kinds that carry one, as a [`Error::Context`] around the others.
    pub(crate) fn context(mut self, context: impl std::fmt::Display) -> Error {
        match self {
            Error::Job {
                ref mut message, ..
            }
            | Error::Limits {
                ref mut message, ..
            }
            | Error::Request { ref mut message }
            | Error::Run {
                ref mut message, ..
            }
            | Error::Results {
                ref mut message, ..
            } => {
                *message = format!("{context}: {message}");
                self
            }
            other => Error::Context {
                context: context.to_string(),
                source: Box::new(other),
            },
        }
    }

    /// The message and each cause's, joined by ": ", each cause once (an I/O
    /// error wrapped by a CSV or JSON error would otherwise appear twice): the
    /// account the command line prints.
    pub fn chain_message(&self) -> String {
        let mut msg = String::new();
        let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(self);
        while let Some(e) = cause {
            let text = e.to_string();
            if !msg.contains(&text) {
                if !msg.is_empty() {
                    msg.push_str(": ");
                }
                msg.push_str(&text);
            }
            cause = e.source();
        }
        msg
    }
}

/// Wrapping another crate's error as the source of a kind of [`Error`].
pub(crate) trait ResultExt<T> {
    /// As a [`Error::Job`] with `message`.
    fn or_job(self, message: impl FnOnce() -> String) -> Result<T>;
    /// As a [`Error::Run`] with `message`.
    fn or_run(self, message: impl FnOnce() -> String) -> Result<T>;
    /// As a [`Error::Results`] with `message`.
    fn or_results(self, message: impl FnOnce() -> String) -> Result<T>;
    /// As a [`Error::Input`] at `file:line:column`.
    fn or_input(
        self,
        file: &str,
        line: u64,
        column: u64,
        message: impl FnOnce() -> String,
    ) -> Result<T>;
}

impl<T, E: std::error::Error + Send + Sync + 'static> ResultExt<T> for std::result::Result<T, E> {
    fn or_job(self, message: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| Error::Job {
            message: message(),
            source: Some(Box::new(e)),
        })
    }

    fn or_run(self, message: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| Error::Run {
            message: message(),
            source: Some(Box::new(e)),
        })
    }

    fn or_results(self, message: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| Error::Results {
            message: message(),
            source: Some(Box::new(e)),
        })
    }

    fn or_input(
        self,
        file: &str,
        line: u64,
        column: u64,
        message: impl FnOnce() -> String,
    ) -> Result<T> {
        self.map_err(|e| Error::Input {
            file: file.to_string(),
            line,
            column,
            message: message(),
            source: Some(Box::new(e)),
        })
    }
}

/// [`Error::context`] on a result.
pub(crate) trait Context<T> {
    /// The error with `context` before it.
    fn context_with<C: std::fmt::Display>(self, context: impl FnOnce() -> C) -> Result<T>;
}

impl<T> Context<T> for Result<T> {
    fn context_with<C: std::fmt::Display>(self, context: impl FnOnce() -> C) -> Result<T> {
        self.map_err(|e| e.context(context()))
    }
}

/// `return Err(Error::KIND(format!(…)))`: `fail!(job, "…", …)`.
macro_rules! fail {
    ($kind:ident, $($arg:tt)*) => {
        return Err($crate::error::Error::$kind(format!($($arg)*)))
    };
}
pub(crate) use fail;
