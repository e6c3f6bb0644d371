//! `dexcut._dexcut`: the Python extension module behind the `dexcut` package
//! (`python/dexcut/`). A thin layer over the `dexcut` library: each function
//! calls one library function with the GIL released, hands the results to
//! Python (the steps' and the column grid's values as NumPy arrays that own
//! the Rust buffers, no copy) and turns a [`dexcut::Error`] into the Python
//! exception of its kind. The Python package wraps these in typed classes.
#![allow(unsafe_code)] // PyO3's macros expand to unsafe code.

use std::path::PathBuf;

use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

mod errors;
mod progress;

use errors::to_py;

/// A job read and checked ([`dexcut::Setup`]).
#[pyclass(module = "dexcut._dexcut", name = "Setup")]
struct PySetup {
    inner: dexcut::Setup,
}

#[pymethods]
impl PySetup {
    /// The job file.
    #[getter]
    fn job_path(&self) -> PathBuf {
        self.inner.job_path.clone()
    }

    /// The job's name in messages (its file, as given).
    #[getter]
    fn name(&self) -> String {
        self.inner.job.name.clone()
    }

    /// Every file the run reads: the job, its program, stock mesh and design model.
    #[getter]
    fn input_files(&self) -> Vec<PathBuf> {
        self.inner.input_files(&self.inner.job_path)
    }

    /// The program file, as named in messages.
    #[getter]
    fn program(&self) -> String {
        self.inner.program.file.clone()
    }

    /// The set-up's warnings (program form, tool changes, spindle speeds,
    /// grid), as summary.json's JSON text.
    fn warnings_json(&self) -> PyResult<String> {
        json(&self.inner.warnings)
    }

    /// The set-up (material, tools, machine, limits), as summary.json's
    /// `setup` JSON text.
    fn info_json(&self) -> PyResult<String> {
        json(&self.inner.info())
    }

    /// The stock's column grid: (nx, ny, x0_mm, y0_mm, spacing_mm).
    #[getter]
    fn grid(&self) -> (usize, usize, f64, f64, f64) {
        let g = match &self.inner.tiling {
            Some(t) => t.grid,
            None => *self.inner.stock.grid(),
        };
        (g.nx, g.ny, g.x_mm(0), g.y_mm(0), g.spacing_mm)
    }

    fn __repr__(&self) -> String {
        format!(
            "Setup({:?}, program={:?})",
            self.inner.job.name, self.inner.program.file
        )
    }
}

/// A simulation's run, kept to write its files ([`dexcut::Simulation`]).
#[pyclass(module = "dexcut._dexcut", name = "Run")]
struct PyRun {
    inner: dexcut::Simulation,
}

#[pymethods]
impl PyRun {
    /// Write the steps and the column grid into the existing folder `out`
    /// ([`dexcut::Simulation::write_files`]); returns the steps' format written.
    #[pyo3(signature = (out, steps_format = "auto", columns_csv = false))]
    fn write_files(
        &self,
        py: Python<'_>,
        out: PathBuf,
        steps_format: &str,
        columns_csv: bool,
    ) -> PyResult<&'static str> {
        let format = steps_format_of(steps_format)?;
        let sim = &self.inner;
        let written = py
            .detach(|| sim.write_files(&out, columns_csv, format))
            .map_err(to_py)?;
        Ok(steps_format_name(written))
    }
}

fn steps_format_of(name: &str) -> PyResult<dexcut::StepsFormat> {
    Ok(match name {
        "auto" => dexcut::StepsFormat::Auto,
        "csv" => dexcut::StepsFormat::Csv,
        "npy" => dexcut::StepsFormat::Npy,
        "both" => dexcut::StepsFormat::Both,
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "steps_format {other:?}: one of auto, csv, npy, both"
            )))
        }
    })
}

fn steps_format_name(f: dexcut::StepsFormat) -> &'static str {
    match f {
        dexcut::StepsFormat::Auto => "auto",
        dexcut::StepsFormat::Csv => "csv",
        dexcut::StepsFormat::Npy => "npy",
        dexcut::StepsFormat::Both => "both",
    }
}

fn json<T: serde::Serialize + ?Sized>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| PyException::new_err(e.to_string()))
}

/// Load a job file and everything it names, checked before any work.
#[pyfunction]
#[pyo3(signature = (job_path, grid = None, settings = None, progress = None))]
fn load(
    py: Python<'_>,
    job_path: PathBuf,
    grid: Option<f64>,
    settings: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PySetup> {
    let _bar = progress::Installed::new(progress);
    let inner = py
        .detach(|| dexcut::Setup::load_with(&job_path, grid, settings.as_deref()))
        .map_err(to_py)?;
    Ok(PySetup { inner })
}

/// The steps of a run as a dict of NumPy arrays, each owning its Rust buffer.
fn steps_dict<'py>(py: Python<'py>, columns: dexcut::StepColumns) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let dexcut::StepColumns {
        head,
        bands,
        band_count,
        loads,
        breaks,
        line,
        rapid,
        tool,
    } = columns;
    let n = line.len();
    for (name, col) in dexcut::StepColumns::HEAD.iter().zip(head) {
        d.set_item(*name, col.into_pyarray(py))?;
    }
    let bands = bands
        .into_pyarray(py)
        .reshape([n, band_count])
        .map_err(|e| PyException::new_err(e.to_string()))?;
    d.set_item(dexcut::StepColumns::BANDS, bands)?;
    for (name, col) in dexcut::StepColumns::LOADS.iter().zip(loads) {
        d.set_item(*name, col.into_pyarray(py))?;
    }
    d.set_item("breaks", breaks.into_pyarray(py))?;
    d.set_item("line", line.into_pyarray(py))?;
    d.set_item("rapid", rapid.into_pyarray(py))?;
    d.set_item("tool", tool.into_pyarray(py))?;
    Ok(d)
}

/// The column grid as a dict of `(ny, nx)` NumPy arrays, each owning its Rust buffer.
fn columns_dict<'py>(py: Python<'py>, grid: dexcut::ColumnGrid) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let shape = [grid.grid.ny, grid.grid.nx];
    fn f32s<'py>(py: Python<'py>, v: Vec<f32>, shape: [usize; 2]) -> PyResult<Bound<'py, PyAny>> {
        Ok(v.into_pyarray(py)
            .reshape(shape)
            .map_err(|e| PyException::new_err(e.to_string()))?
            .into_any())
    }
    fn i32s<'py>(py: Python<'py>, v: Vec<i32>, shape: [usize; 2]) -> PyResult<Bound<'py, PyAny>> {
        Ok(v.into_pyarray(py)
            .reshape(shape)
            .map_err(|e| PyException::new_err(e.to_string()))?
            .into_any())
    }
    d.set_item("top_mm", f32s(py, grid.top_mm, shape)?)?;
    d.set_item("last_step", i32s(py, grid.last_step, shape)?)?;
    d.set_item("error_um", f32s(py, grid.error_um, shape)?)?;
    if let Some(v) = grid.design_um {
        d.set_item("design_um", f32s(py, v, shape)?)?;
    }
    if let Some(v) = grid.line {
        d.set_item("line", i32s(py, v, shape)?)?;
    }
    Ok(d)
}

/// Simulate the job's program; writes nothing. Returns (summary JSON, steps,
/// columns, grid, design JSON or None, run).
#[pyfunction]
#[pyo3(signature = (setup, actual_path = false, progress = None))]
fn simulate<'py>(
    py: Python<'py>,
    setup: PyRef<'py, PySetup>,
    actual_path: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let _bar = progress::Installed::new(progress);
    let inner = &setup.inner;
    let (sim, steps, grid) = py
        .detach(|| {
            let sim = dexcut::simulate(inner, actual_path)?;
            let steps = sim.run.step_columns();
            let grid = sim.column_grid();
            Ok::<_, dexcut::Error>((sim, steps, grid))
        })
        .map_err(to_py)?;
    let out = PyDict::new(py);
    out.set_item("summary", json(&sim.summary)?)?;
    out.set_item(
        "grid",
        (
            grid.grid.nx,
            grid.grid.ny,
            grid.grid.x0_mm,
            grid.grid.y0_mm,
            grid.grid.spacing_mm,
        ),
    )?;
    out.set_item(
        "design",
        match &sim.design {
            Some((_, info)) => Some(json(info)?),
            None => None,
        },
    )?;
    out.set_item("steps", steps_dict(py, steps)?)?;
    out.set_item("columns", columns_dict(py, grid)?)?;
    out.set_item("run", Py::new(py, PyRun { inner: sim })?)?;
    Ok(out)
}

/// Re-time the job's program and write the results folder `out`; returns
/// summary.json's text.
#[pyfunction]
#[pyo3(signature = (setup, out, force = false, progress = None))]
fn optimize(
    py: Python<'_>,
    mut setup: PyRefMut<'_, PySetup>,
    out: PathBuf,
    force: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let _bar = progress::Installed::new(progress);
    let inner = &mut setup.inner;
    let optimized = py
        .detach(|| dexcut::optimize(inner, &out, force))
        .map_err(to_py)?;
    json(&optimized.summary)
}

/// Run the drive model over the planned motion; returns (JSON of the
/// evaluation, the estimated actual positions as an `(n, 3)` array).
#[pyfunction]
#[pyo3(signature = (setup, sweep = false))]
fn evaluate<'py>(
    py: Python<'py>,
    setup: PyRef<'py, PySetup>,
    sweep: bool,
) -> PyResult<(String, Bound<'py, PyAny>)> {
    let inner = &setup.inner;
    let ev = py
        .detach(|| dexcut::evaluate(inner, sweep))
        .map_err(to_py)?;
    let doc = serde_json::json!({
        "drive": ev.drive,
        "weights": ev.weights,
        "evaluation": ev.evaluation,
        "precomp_error_before_mm": ev.precomp.error_before_mm,
        "precomp_error_after_mm": ev.precomp.error_after_mm,
        "precomp_iterations": ev.precomp.iterations,
        "precomp_trajectory_error_mm": ev.precomp_trajectory_error_mm,
        "sweep": ev.sweep,
        "best": ev.best,
    });
    let n = ev.actual_mm.len();
    let flat: Vec<f64> = ev.actual_mm.into_iter().flatten().collect();
    let actual = flat
        .into_pyarray(py)
        .reshape([n, 3])
        .map_err(|e| PyException::new_err(e.to_string()))?
        .into_any();
    Ok((doc.to_string(), actual))
}

/// Build report.html, the maps and stock.glb in the results folder `out`;
/// returns their paths (html, error_map_png, design_map_png or None, stock_glb).
#[pyfunction]
fn report(py: Python<'_>, out: PathBuf) -> PyResult<(PathBuf, PathBuf, Option<PathBuf>, PathBuf)> {
    let files = py.detach(|| dexcut::report(&out)).map_err(to_py)?;
    Ok((
        files.html,
        files.error_map_png,
        files.design_map_png,
        files.stock_glb,
    ))
}

/// Read a summary.json through the library's types (checked as `report`
/// checks it); returns its text as the library writes it.
#[pyfunction]
fn read_summary(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    let doc = py.detach(|| dexcut::summary::read(&path)).map_err(to_py)?;
    match doc {
        dexcut::summary::SummaryDoc::Simulate(d) => json(&d),
        dexcut::summary::SummaryDoc::Optimize(d) => json(&d),
        dexcut::summary::SummaryDoc::Operations(d) => json(&d),
    }
}

/// Whether `path` is a job file rather than a G-code program.
#[pyfunction]
fn is_job_file(path: PathBuf) -> bool {
    dexcut::fitted_job::is_job_file(&path)
}

/// A job fitted to a G-code program, as `dexcut job` writes it: (TOML text, notes).
#[pyfunction]
#[pyo3(signature = (program, tool = None, grid = None))]
fn fit_job(
    py: Python<'_>,
    program: PathBuf,
    tool: Option<String>,
    grid: Option<f64>,
) -> PyResult<(String, Vec<String>)> {
    let fitted = py
        .detach(|| {
            let tool = tool
                .as_deref()
                .map(dexcut::fitted_job::parse_tool_arg)
                .transpose()?;
            dexcut::fitted_job::fit(&program, tool.as_ref(), grid)
        })
        .map_err(to_py)?;
    Ok((fitted.toml, fitted.notes))
}

/// The text of a job with numbers changed (`[("limits.mrr_max", 80.0)]`),
/// its relative paths made absolute ([`dexcut::job_variant`]).
#[pyfunction]
fn job_variant(
    text: &str,
    name: &str,
    base_dir: PathBuf,
    overrides: Vec<(String, f64)>,
) -> PyResult<String> {
    dexcut::job_variant(text, name, &base_dir, &overrides).map_err(to_py)
}

/// One command as the `dexcut` binary runs it (`simulate` or `optimize` of a
/// job file, or of a G-code program with a fitted job; `job_text`: run this
/// job text instead, written to `out/input/job.toml` with the results, its
/// program `program`), writing the same results folder. Returns
/// summary.json's text and the warnings told before the work.
#[pyfunction]
#[pyo3(signature = (command, job, out, grid = None, tool = None, force = false, steps_format = "auto", job_text = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn run_command(
    py: Python<'_>,
    command: &str,
    job: PathBuf,
    out: PathBuf,
    grid: Option<f64>,
    tool: Option<String>,
    force: bool,
    steps_format: &str,
    job_text: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Vec<String>)> {
    let format = steps_format_of(steps_format)?;
    let simulate = match command {
        "simulate" => true,
        "optimize" => false,
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "command {other:?}: simulate or optimize"
            )))
        }
    };
    let _bar = progress::Installed::new(progress);
    let told = std::sync::Mutex::new(Vec::<String>::new());
    let result = py.detach(|| {
        let on_warning = |w: &dyn std::fmt::Display| {
            told.lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(w.to_string());
        };
        let fitted = match job_text {
            Some(toml) => Some(dexcut::fitted_job::FittedJob {
                program: job.clone(),
                toml,
                notes: Vec::new(),
            }),
            None if dexcut::fitted_job::is_job_file(&job) => None,
            None => {
                let tool = tool
                    .as_deref()
                    .map(dexcut::fitted_job::parse_tool_arg)
                    .transpose()?;
                Some(dexcut::fitted_job::fit(&job, tool.as_ref(), grid)?)
            }
        };
        let arg = match &fitted {
            Some(f) => dexcut::commands::JobArg::Fitted(f),
            None => dexcut::commands::JobArg::File(&job),
        };
        let opts = dexcut::commands::RunOptions {
            grid_mm: grid,
            force,
            columns_csv: false,
            steps_format: format,
            memory_budget_mb: None,
            save_stock: false,
            on_warning: &on_warning,
        };
        // summary.json's document: one program's, or a job of operations' whole.
        use dexcut::commands::Ran;
        let text = if simulate {
            match dexcut::commands::simulate(arg, &out, false, &opts)? {
                Ran::Program(done) => serde_json::to_string(&done.summary),
                Ran::Operations(seq) => serde_json::to_string(&seq.summary),
            }
        } else {
            match dexcut::commands::optimize(arg, &out, None, &opts)? {
                Ran::Program(done) => serde_json::to_string(&done.summary),
                Ran::Operations(seq) => serde_json::to_string(&seq.summary),
            }
        };
        text.map_err(|e| dexcut::Error::Request {
            message: e.to_string(),
        })
    });
    let told = told.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok((result.map_err(to_py)?, told))
}

/// Remove this process's staging folders and pending files (what a SIGTERM
/// does in the `dexcut` binary); returns what was removed.
#[pyfunction]
fn remove_unfinished() -> Vec<PathBuf> {
    export::atomic::remove_unfinished()
}

/// The step columns' names, in steps.csv's order (the bands as one column).
#[pyfunction]
fn step_column_names(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let mut names: Vec<&str> = dexcut::StepColumns::HEAD.to_vec();
    names.push(dexcut::StepColumns::BANDS);
    names.extend(dexcut::StepColumns::LOADS);
    names.extend(["breaks", "line", "rapid", "tool"]);
    PyList::new(py, names)
}

#[pymodule]
fn _dexcut(m: &Bound<'_, PyModule>) -> PyResult<()> {
    progress::install();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PySetup>()?;
    m.add_class::<PyRun>()?;
    for f in [
        wrap_pyfunction!(load, m)?,
        wrap_pyfunction!(simulate, m)?,
        wrap_pyfunction!(optimize, m)?,
        wrap_pyfunction!(evaluate, m)?,
        wrap_pyfunction!(report, m)?,
        wrap_pyfunction!(read_summary, m)?,
        wrap_pyfunction!(is_job_file, m)?,
        wrap_pyfunction!(fit_job, m)?,
        wrap_pyfunction!(job_variant, m)?,
        wrap_pyfunction!(run_command, m)?,
        wrap_pyfunction!(remove_unfinished, m)?,
        wrap_pyfunction!(step_column_names, m)?,
    ] {
        m.add_function(f)?;
    }
    errors::register(m)?;
    Ok(())
}
