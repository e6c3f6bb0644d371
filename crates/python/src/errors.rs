//! [`dexcut::Error`] as Python exceptions: one class per kind of failure, all
//! under `DexcutError`, the message the `dexcut` binary prints after
//! `error: ` ([`dexcut::Error::chain_message`]), and the kind, file, line
//! and column as attributes.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyList;

create_exception!(_dexcut, DexcutError, PyException, "A step of dexcut failed: the base of every dexcut exception. Attributes: kind, file, line, column, diagnostics.");
create_exception!(
    _dexcut,
    JobError,
    DexcutError,
    "The job file or a key of it (TOML syntax at FILE:LINE:COL, a key out of range)."
);
create_exception!(
    _dexcut,
    ProgramError,
    DexcutError,
    "The G-code reader refused the program: every error at FILE:LINE:COL (diagnostics)."
);
create_exception!(
    _dexcut,
    InputError,
    DexcutError,
    "A text input (point list, measurements, servo samples) at FILE:LINE:COLUMN."
);
create_exception!(
    _dexcut,
    MeshError,
    DexcutError,
    "A stock or design mesh that cannot be read or is not a closed solid."
);
create_exception!(
    _dexcut,
    MotionError,
    DexcutError,
    "The motion could not be planned."
);
create_exception!(
    _dexcut,
    StockError,
    DexcutError,
    "The stock or the sweep refused a parameter or a grid too large."
);
create_exception!(
    _dexcut,
    ExportError,
    DexcutError,
    "An output could not be made or written."
);
create_exception!(
    _dexcut,
    IoError,
    DexcutError,
    "A file or folder could not be read, written or moved."
);
create_exception!(
    _dexcut,
    LimitsError,
    DexcutError,
    "The run would exceed a size bound (file, grid, samples, memory)."
);
create_exception!(
    _dexcut,
    RequestError,
    DexcutError,
    "Something the given inputs cannot serve."
);
create_exception!(
    _dexcut,
    RunError,
    DexcutError,
    "The computation gave no result."
);
create_exception!(
    _dexcut,
    ResultsError,
    DexcutError,
    "A results folder or file is missing, of another version or invalid."
);

/// Add the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("DexcutError", py.get_type::<DexcutError>())?;
    m.add("JobError", py.get_type::<JobError>())?;
    m.add("ProgramError", py.get_type::<ProgramError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("MeshError", py.get_type::<MeshError>())?;
    m.add("MotionError", py.get_type::<MotionError>())?;
    m.add("StockError", py.get_type::<StockError>())?;
    m.add("ExportError", py.get_type::<ExportError>())?;
    m.add("IoError", py.get_type::<IoError>())?;
    m.add("LimitsError", py.get_type::<LimitsError>())?;
    m.add("RequestError", py.get_type::<RequestError>())?;
    m.add("RunError", py.get_type::<RunError>())?;
    m.add("ResultsError", py.get_type::<ResultsError>())?;
    Ok(())
}

/// The error a [`dexcut::Error::Context`] wraps, through every layer.
fn innermost(e: &dexcut::Error) -> &dexcut::Error {
    match e {
        dexcut::Error::Context { source, .. } => innermost(source),
        other => other,
    }
}

/// `FILE:LINE:COL: …` at the start of a message (the job's TOML errors).
fn located(message: &str) -> (Option<String>, Option<u64>, Option<u64>) {
    let head = message.split(": ").next().unwrap_or("");
    let mut parts = head.rsplitn(3, ':');
    let (col, line, file) = (parts.next(), parts.next(), parts.next());
    match (
        file,
        line.and_then(|l| l.parse().ok()),
        col.and_then(|c| c.parse().ok()),
    ) {
        (Some(f), Some(l), Some(c)) if !f.is_empty() => (Some(f.to_string()), Some(l), Some(c)),
        _ => (None, None, None),
    }
}

/// The Python exception of `e`'s kind, its message the CLI's, with the
/// attributes `kind`, `file`, `line`, `column` (None where the kind has no
/// place) and `diagnostics` (a program's errors: (file, line, column, message)).
pub fn to_py(e: dexcut::Error) -> PyErr {
    let message = e.chain_message();
    let mut place: (Option<String>, Option<u64>, Option<u64>) = (None, None, None);
    let mut diagnostics: Vec<(String, u32, u32, String)> = Vec::new();
    let (kind, err) = match innermost(&e) {
        dexcut::Error::Job { message: m, .. } => {
            place = located(m);
            ("job", JobError::new_err(message))
        }
        dexcut::Error::Program { diagnostics: d } => {
            diagnostics = d
                .iter()
                .map(|d| (d.file.clone(), d.line, d.column, d.message.clone()))
                .collect();
            if let Some(first) = d.first() {
                place = (
                    Some(first.file.clone()),
                    Some(first.line.into()),
                    Some(first.column.into()),
                );
            }
            ("program", ProgramError::new_err(message))
        }
        dexcut::Error::Input {
            file, line, column, ..
        } => {
            place = (Some(file.clone()), Some(*line), Some(*column));
            ("input", InputError::new_err(message))
        }
        dexcut::Error::Mesh(_) => ("mesh", MeshError::new_err(message)),
        dexcut::Error::Motion(_) => ("motion", MotionError::new_err(message)),
        dexcut::Error::Stock(_) => ("stock", StockError::new_err(message)),
        dexcut::Error::Export(_) => ("export", ExportError::new_err(message)),
        dexcut::Error::Io { path, .. } => {
            place.0 = Some(path.display().to_string());
            ("io", IoError::new_err(message))
        }
        dexcut::Error::Limits { .. } => ("limits", LimitsError::new_err(message)),
        dexcut::Error::Request { .. } => ("request", RequestError::new_err(message)),
        dexcut::Error::Run { .. } => ("run", RunError::new_err(message)),
        dexcut::Error::Results { .. } => ("results", ResultsError::new_err(message)),
        // A kind added to the library later: the base class.
        _ => ("dexcut", DexcutError::new_err(message)),
    };
    Python::attach(|py| {
        let value = err.value(py);
        let set = || -> PyResult<()> {
            value.setattr("kind", kind)?;
            value.setattr("file", place.0)?;
            value.setattr("line", place.1)?;
            value.setattr("column", place.2)?;
            value.setattr("diagnostics", PyList::new(py, diagnostics)?)?;
            Ok(())
        };
        // An attribute that cannot be set leaves the exception as it is.
        let _ = set();
    });
    err
}
