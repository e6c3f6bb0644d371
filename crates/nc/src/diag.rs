//! Diagnostics with file, line and column, printed as `FILE:LINE:COL: message`.

use std::fmt;

/// How bad a diagnostic is; any `Error` means the program must not be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// The program cannot be run as written (LinuxCNC would refuse it).
    Error,
    /// The program runs, but something in it is likely a mistake.
    Warning,
}

/// One problem found in a program.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// The file name given to [`crate::parse`].
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based character column.
    pub column: u32,
    /// What is wrong, in LinuxCNC's words where it has them.
    pub message: String,
    /// Error or warning.
    pub severity: Severity,
}

impl Diagnostic {
    /// True for errors (the program must not be used), false for warnings.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.line, self.column, self.message
        )
    }
}
