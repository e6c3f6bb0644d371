"""dexcut from Python: Z-dexel cutting simulation and feed optimisation for
3-axis milling.

The pipeline mirrors the Rust library (``crates/dexcut``)::

    import dexcut
    setup = dexcut.load("examples/boss_contour/job.toml")   # checked before any work
    sim = dexcut.simulate(setup)                            # writes nothing
    sim.summary.peak_force_n                                # typed summary
    sim.steps["force_n"]                                    # numpy array, one value per step
    sim.columns["error_um"]                                 # numpy array (ny, nx); sim.x_mm, sim.y_mm
    opt = dexcut.optimize(setup, "out/boss")                # writes the results folder
    res = dexcut.read_results("out/boss")                   # any results folder, as numpy arrays
    dexcut.report("out/boss")                               # report.html, maps, stock.glb

Every run releases the GIL; ``progress=`` takes a callable
``(done, total, what)`` (``dexcut.tqdm_progress()`` draws tqdm bars).
Failures raise a :class:`DexcutError` subclass named by the kind of failure
(:class:`JobError`, :class:`ProgramError`, …) with the message the ``dexcut``
binary prints, and ``kind``, ``file``, ``line``, ``column`` and
``diagnostics`` attributes. Batch runs on Dask: ``python -m dexcut batch``
(:mod:`dexcut.batch`).
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Union

import numpy as np

from . import _dexcut
from ._dexcut import (
    DexcutError,
    ExportError,
    InputError,
    IoError,
    JobError,
    LimitsError,
    MeshError,
    MotionError,
    ProgramError,
    RequestError,
    ResultsError,
    RunError,
    Setup,
    StockError,
)
from ._summary import (
    GridInfo,
    OperationLine,
    OperationsSummary,
    OptimizeSummary,
    SimulateSummary,
    Summary,
    ToolPeaks,
    Warning,
    document,
)

__version__: str = _dexcut.__version__

__all__ = [
    "load",
    "simulate",
    "optimize",
    "evaluate",
    "report",
    "read_results",
    "fit_job",
    "tqdm_progress",
    "Setup",
    "Simulation",
    "Optimized",
    "Results",
    "DriveEvaluation",
    "ReportFiles",
    "Summary",
    "SimulateSummary",
    "OptimizeSummary",
    "OperationLine",
    "OperationsSummary",
    "Warning",
    "ToolPeaks",
    "GridInfo",
    "DexcutError",
    "JobError",
    "ProgramError",
    "InputError",
    "MeshError",
    "MotionError",
    "StockError",
    "ExportError",
    "IoError",
    "LimitsError",
    "RequestError",
    "RunError",
    "ResultsError",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Optional[Callable[[int, int, str], Any]]


def load(
    job_path: PathLike,
    grid: Optional[float] = None,
    *,
    tool: Optional[str] = None,
    settings: Optional[PathLike] = None,
    progress: Progress = None,
) -> Setup:
    """Load a job file (TOML) and everything it names (program, stock mesh,
    design model), each checked before any work.

    ``grid`` overrides the stock's column spacing, mm; ``settings`` puts a
    fragment written by ``evaluate --sweep`` over the job's machine and
    drive. Given a G-code program instead of a job file, a job is fitted to
    it as ``dexcut simulate part.nc`` does (``tool``: ``"flat:6"``,
    ``"ball:3.175"``, ``"bull:10:1"``; else from the program's comments).

    Raises a :class:`DexcutError` subclass (:class:`JobError` with the
    key or ``file:line:col``, :class:`ProgramError` with every diagnostic).
    """
    path = Path(job_path)
    if not _dexcut.is_job_file(path):
        text, _notes = fit_job(path, tool=tool, grid=grid)
        folder = tempfile.mkdtemp(prefix="dexcut-fitted-")
        job = Path(folder) / "job.toml"
        job.write_text(text, encoding="utf-8")
        return _dexcut.load(job, None, None if settings is None else Path(settings), progress)
    if tool is not None:
        raise RequestError(
            f"tool is for a G-code program given instead of a job; {path} is a job: its [tool] gives the tool"
        )
    return _dexcut.load(path, grid, None if settings is None else Path(settings), progress)


def fit_job(program: PathLike, tool: Optional[str] = None, grid: Optional[float] = None):
    """The job ``dexcut job PROGRAM`` writes: (TOML text, the notes of what was guessed)."""
    return _dexcut.fit_job(Path(program), tool, grid)


class _Grid:
    grid: GridInfo
    columns: Dict[str, np.ndarray]

    @property
    def x_mm(self) -> np.ndarray:
        """X of each column's centre, mm: ``columns[name][iy, ix]`` is at (x_mm[ix], y_mm[iy])."""
        g = self.grid
        return g.x0_mm + np.arange(g.nx) * g.spacing_mm

    @property
    def y_mm(self) -> np.ndarray:
        """Y of each row of columns' centre, mm."""
        g = self.grid
        return g.y0_mm + np.arange(g.ny) * g.spacing_mm

    @property
    def extent(self) -> List[float]:
        """``[x_min, x_max, y_min, y_max]`` of the grid's cells, for ``imshow(extent=…, origin="lower")``."""
        g = self.grid
        h = g.spacing_mm / 2
        return [g.x0_mm - h, g.x0_mm + (g.nx - 0.5) * g.spacing_mm, g.y0_mm - h, g.y0_mm + (g.ny - 0.5) * g.spacing_mm]


class Simulation(_Grid):
    """A simulated program (:func:`simulate`), held in memory.

    * ``summary``: the run's numbers (:class:`Summary`), ``warnings`` its warnings;
    * ``steps``: one numpy array per column of steps.csv, row i = step i
      (``t_s``, ``x``, ``y``, ``z``, ``feed_mm_min``, ``volume_mm3``,
      ``mrr_mm3_s``, ``band_mm3`` of shape (steps, bands), ``shank_mm3``,
      ``force_n``, …, ``stress_mpa``, ``breaks``, ``line``, ``rapid``,
      ``tool``): the values of the steps' ``.npy`` arrays bit for bit, each
      owning the buffer the library made (no copy);
    * ``columns``: the column grid, ``top_mm``, ``last_step``, ``error_um``
      (and with ``[design]`` ``design_um``, ``line``), each shaped (ny, nx),
      with ``x_mm``, ``y_mm``, ``extent``;
    * ``design``: the ``[design]`` comparison (a dict) or None.
    """

    def __init__(self, raw: Dict[str, Any]):
        self.summary: Summary = Summary.from_dict(json.loads(raw["summary"]))
        nx, ny, x0, y0, h = raw["grid"]
        self.grid = GridInfo.from_dict({"nx": nx, "ny": ny, "x0_mm": x0, "y0_mm": y0, "spacing_mm": h})
        self.steps: Dict[str, np.ndarray] = raw["steps"]
        self.columns: Dict[str, np.ndarray] = raw["columns"]
        self.design: Optional[Dict[str, Any]] = None if raw["design"] is None else json.loads(raw["design"])
        self._run = raw["run"]

    @property
    def warnings(self) -> List[Warning]:
        """The run's warnings, each with kind, line and message."""
        return self.summary.warnings

    def write(self, out: PathLike, steps_format: str = "auto", columns_csv: bool = False) -> str:
        """Write the steps (``steps_format``: auto, csv, npy or both) and the
        column grid into the existing folder ``out``; returns the format written."""
        return self._run.write_files(Path(out), steps_format, columns_csv)

    def __repr__(self) -> str:
        s = self.summary
        return (
            f"Simulation(steps={s.steps}, cycle_time_s={s.cycle_time_s:.4g}, "
            f"peak_force_n={s.peak_force_n:.4g}, peak_deflection_um={s.peak_deflection_um:.4g}, "
            f"warnings={len(s.warnings)})"
        )


def simulate(setup: Setup, actual_path: bool = False, *, progress: Progress = None) -> Simulation:
    """Simulate the job's program as written (``actual_path``: along the
    drive model's estimate of the axes' path). Writes nothing; the GIL is
    released while it runs."""
    return Simulation(_dexcut.simulate(setup, actual_path, progress))


class Results(_Grid):
    """A results folder read back (:func:`read_results`): ``summary`` (a
    :class:`SimulateSummary` or :class:`OptimizeSummary`), ``steps`` (and
    for optimize ``steps_before``) as numpy arrays, ``columns`` (ny, nx)
    with ``x_mm``/``y_mm``, ``manifest`` (run id and files), ``path``.
    A job of ``[[operations]]``'s folder: ``summary`` an
    :class:`OperationsSummary`, ``columns`` the job's grid (``top_mm``,
    ``last_operation``, ``error_um``), no steps, and ``operations`` each
    operation's folder read back, by its folder name."""

    def __init__(self, path: Path):
        self.path = path
        summary_path = path / "summary.json"
        _dexcut.read_summary(summary_path)  # checked by the library's types and version
        raw = json.loads(summary_path.read_text(encoding="utf-8"))
        self.summary: Union[SimulateSummary, OptimizeSummary, OperationsSummary] = document(raw)
        manifest = path / "manifest.json"
        self.manifest: Optional[Dict[str, Any]] = (
            json.loads(manifest.read_text(encoding="utf-8")) if manifest.exists() else None
        )
        self.grid, self.columns = _read_grid(path)
        self.steps: Optional[Dict[str, np.ndarray]] = _read_steps(path, "steps")
        self.steps_before: Optional[Dict[str, np.ndarray]] = _read_steps(path, "steps_before")
        self.operations: Dict[str, "Results"] = (
            {op.folder: Results(path / op.folder) for op in self.summary.operations}
            if isinstance(self.summary, OperationsSummary)
            else {}
        )

    @property
    def warnings(self) -> List[Warning]:
        """The warnings of the run (optimize: of the optimized program)."""
        s = self.summary
        if isinstance(s, OptimizeSummary):
            return [] if s.after is None else s.after.warnings
        if isinstance(s, OperationsSummary):
            return [w for r in self.operations.values() for w in r.warnings]
        return s.warnings

    def __repr__(self) -> str:
        return f"Results({str(self.path)!r}, command={self.summary.command!r})"


def _read_grid(path: Path):
    meta = json.loads((path / "columns.json").read_text(encoding="utf-8"))
    grid = GridInfo.from_dict({k: meta[k] for k in ("nx", "ny", "x0_mm", "y0_mm", "spacing_mm")})
    columns = {a["name"]: np.load(path / a["file"], allow_pickle=False) for a in meta["arrays"]}
    return grid, columns


def _read_steps(path: Path, stem: str) -> Optional[Dict[str, np.ndarray]]:
    table = path / f"{stem}.json"
    if table.exists():
        meta = json.loads(table.read_text(encoding="utf-8"))
        return {c["name"]: np.load(path / c["file"], allow_pickle=False) for c in meta["columns"]}
    csv = path / f"{stem}.csv"
    if not csv.exists():
        return None
    return _steps_from_csv(csv)


_INT_COLUMNS = {"breaks": np.uint8, "line": np.uint32, "rapid": np.uint8, "tool": np.uint32}


def _steps_from_csv(csv: Path) -> Dict[str, np.ndarray]:
    """steps.csv as the binary form's arrays: f64 columns (each printed in its
    shortest round-trip form, so read back bit for bit), the band volumes as
    one (steps, bands) array up to the highest band any step cut."""
    with open(csv, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
    if data.shape[0] == 0:
        data = np.zeros((0, len(header)))
    out: Dict[str, np.ndarray] = {}
    bands = [i for i, h in enumerate(header) if h.startswith("band_") and h.endswith("_mm3")]
    for i, name in enumerate(header):
        if name == "step" or i in bands:
            continue
        if name == "shank_mm3":
            block = data[:, bands] if bands else np.zeros((data.shape[0], 0))
            cut = np.nonzero(block.any(axis=0))[0]
            width = int(cut[-1]) + 1 if len(cut) else 0
            out["band_mm3"] = np.ascontiguousarray(block[:, :width])
        col = data[:, i]
        out[name] = col.astype(_INT_COLUMNS[name]) if name in _INT_COLUMNS else np.ascontiguousarray(col)
    return out


def read_results(out: PathLike) -> Results:
    """Read a results folder written by ``simulate`` or ``optimize`` (the
    CLI's, :func:`optimize`'s or a batch's): summary.json through the
    library's types, the steps and the column grid as numpy arrays."""
    return Results(Path(out))


class Optimized:
    """What :func:`optimize` made: ``summary`` (:class:`OptimizeSummary`,
    ``before`` and ``after`` each a :class:`Summary`), ``path`` (the results
    folder), ``results()`` to read its arrays."""

    def __init__(self, path: Path):
        self.path = path
        self.summary: OptimizeSummary = OptimizeSummary.from_dict(
            json.loads((path / "summary.json").read_text(encoding="utf-8"))
        )

    @property
    def warnings(self) -> List[Warning]:
        """Warnings of the optimized program's run."""
        return [] if self.summary.after is None else self.summary.after.warnings

    def results(self) -> Results:
        """The results folder read back (steps before and after, column grid)."""
        return read_results(self.path)

    def __repr__(self) -> str:
        b, a = self.summary.before, self.summary.after
        return f"Optimized({str(self.path)!r}, cycle_time_s {b.cycle_time_s:.4g} -> {a.cycle_time_s:.4g})"  # type: ignore[union-attr]


def optimize(setup: Setup, out: PathLike, force: bool = False, *, progress: Progress = None) -> Optimized:
    """Re-time the job's program under its ``[limits]`` and write the results
    folder ``out`` whole (optimized.nc, servo.csv, steps before and after,
    column grid, summary.json). The numbers after are optimized.nc read back
    and simulated. ``force`` allows a folder holding the job's inputs. The
    GIL is released while it runs."""
    path = Path(out)
    _dexcut.optimize(setup, path, force, progress)
    return Optimized(path)


class DriveEvaluation:
    """:func:`evaluate`'s result: ``evaluation`` (S2's trajectory error, time,
    jerk, V), ``drive``, ``weights``, the pre-compensation's errors,
    ``sweep`` rows and ``best`` (with ``sweep=True``), and ``actual_mm``,
    the estimated actual tool position every servo period, shape (n, 3)."""

    def __init__(self, doc: Dict[str, Any], actual_mm: np.ndarray):
        self._doc = doc
        self.drive: Dict[str, Any] = doc["drive"]
        self.weights: Dict[str, Any] = doc["weights"]
        self.evaluation: Dict[str, Any] = doc["evaluation"]
        self.precomp_error_before_mm: float = doc["precomp_error_before_mm"]
        self.precomp_error_after_mm: float = doc["precomp_error_after_mm"]
        self.precomp_trajectory_error_mm: float = doc["precomp_trajectory_error_mm"]
        self.sweep: List[Dict[str, Any]] = doc["sweep"]
        self.best: Optional[int] = doc["best"]
        self.actual_mm = actual_mm

    def to_dict(self) -> Dict[str, Any]:
        """Everything but ``actual_mm``, as JSON values."""
        return json.loads(json.dumps(self._doc))


def evaluate(setup: Setup, sweep: bool = False) -> DriveEvaluation:
    """Run the planned motion through the job's drive model (``[servo]``) and
    score it (S2); with ``sweep``, also a grid of settings. Writes nothing."""
    doc, actual = _dexcut.evaluate(setup, sweep)
    return DriveEvaluation(json.loads(doc), actual)


class ReportFiles:
    """The files :func:`report` wrote."""

    def __init__(self, html: Path, error_map_png: Path, design_map_png: Optional[Path], stock_glb: Path):
        self.html = html
        self.error_map_png = error_map_png
        self.design_map_png = design_map_png
        self.stock_glb = stock_glb

    def __repr__(self) -> str:
        return f"ReportFiles(html={str(self.html)!r})"


def report(out: PathLike) -> ReportFiles:
    """Build report.html, error_map.png (design_map.png) and stock.glb in a
    results folder, from its files alone."""
    return ReportFiles(*_dexcut.report(Path(out)))


def tqdm_progress(**tqdm_kwargs: Any) -> Callable[[int, int, str], None]:
    """A progress callback drawing one tqdm bar per sweep (``tqdm.auto``: a
    widget in notebooks). Pass it as ``progress=``."""
    from tqdm.auto import tqdm  # type: ignore[import-not-found]

    bars: Dict[str, Any] = {}

    def callback(done: int, total: int, what: str) -> None:
        bar = bars.get(what)
        if bar is None:
            bar = bars[what] = tqdm(total=total, desc=what, **tqdm_kwargs)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()
            del bars[what]

    return callback
