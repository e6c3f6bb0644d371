"""Typed views of summary.json: the numbers of a run (:class:`Summary`), its
warnings (:class:`Warning`), and the documents `simulate` and `optimize`
write (:class:`SimulateSummary`, :class:`OptimizeSummary`).

Each class is built from the JSON the library writes (``from_dict``) and
gives it back unchanged (``to_dict``), so values compare exactly with a
results folder's summary.json. JSON ``null`` (a NaN, or a value that does
not apply) is ``None``.
"""
from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional

__all__ = [
    "Warning",
    "ToolPeaks",
    "GridInfo",
    "Summary",
    "SimulateSummary",
    "OptimizeSummary",
    "OperationLine",
    "OperationsSummary",
]


class _FromDict:
    """``from_dict`` and ``to_dict`` for the dataclasses below: nested
    dataclasses are built from their dicts; ``to_dict`` returns the JSON the
    object was read from, keys the class does not name included."""

    _raw: Dict[str, Any]

    @classmethod
    def from_dict(cls, d: Dict[str, Any]):  # type: ignore[no-untyped-def]
        hints = typing.get_type_hints(cls)
        kwargs = {}
        for f in dataclasses.fields(cls):  # type: ignore[arg-type]
            if f.name.startswith("_") or f.name not in d:
                continue
            kwargs[f.name] = _convert(hints[f.name], d[f.name])
        obj = cls(**kwargs)
        object.__setattr__(obj, "_raw", d)
        return obj

    def to_dict(self) -> Dict[str, Any]:
        """The JSON object this was read from (a copy)."""
        import copy

        return copy.deepcopy(self._raw)


def _convert(hint: Any, value: Any) -> Any:
    if value is None:
        return None
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin is typing.Union:
        inner = [a for a in args if a is not type(None)]
        return _convert(inner[0], value) if len(inner) == 1 else value
    if origin in (list, List) and args and isinstance(value, list):
        return [_convert(args[0], v) for v in value]
    if isinstance(hint, type) and issubclass(hint, _FromDict) and isinstance(value, dict):
        return hint.from_dict(value)
    return value


@dataclass(frozen=True)
class Warning(_FromDict):
    """A warning: its kind (``rapid_cut``, ``shank_contact``, ``limit_exceeded``,
    …), the first program line concerned (None for the whole program), the
    worst value in ``unit``, the steps and lines concerned, and the message."""

    kind: str = ""
    line: Optional[int] = None
    value: Optional[float] = None
    unit: str = ""
    steps: int = 0
    lines: List[int] = field(default_factory=list)
    message: str = ""
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def __str__(self) -> str:
        return f"line {self.line}: {self.message}" if self.line is not None else self.message


@dataclass(frozen=True)
class ToolPeaks(_FromDict):
    """Peaks of one tool's steps."""

    tool: int = 0
    steps: int = 0
    removed_volume_mm3: float = 0.0
    time_s: float = 0.0
    peak_mrr_mm3_s: float = 0.0
    peak_force_n: float = 0.0
    peak_deflection_um: float = 0.0
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class GridInfo(_FromDict):
    """The column grid: ``nx`` × ``ny`` columns, column (ix, iy) centred at
    (x0_mm + ix·spacing_mm, y0_mm + iy·spacing_mm)."""

    nx: int = 0
    ny: int = 0
    x0_mm: float = 0.0
    y0_mm: float = 0.0
    spacing_mm: float = 0.0
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class Summary(_FromDict):
    """The numbers of one run (summary.json's run part; ``before`` and
    ``after`` of optimize). Units are in the names (docs/guide/outputs.md)."""

    initial_volume_mm3: float = 0.0
    final_volume_mm3: float = 0.0
    removed_volume_mm3: float = 0.0
    cycle_time_s: float = 0.0
    peak_mrr_mm3_s: float = 0.0
    peak_mrr_windowed_mm3_s: float = 0.0
    peak_force_n: float = 0.0
    peak_force_revolution_n: float = 0.0
    peak_power_w: float = 0.0
    peak_torque_nm: float = 0.0
    peak_deflection_um: float = 0.0
    peak_deflection_at_rupture: bool = False
    tool_breaks_steps: int = 0
    peak_cutting_feed_mm_min: float = 0.0
    peak_tip_deflection_um: float = 0.0
    rigid_peak_deflection_um: float = 0.0
    max_error_um: Optional[float] = None
    min_error_um: Optional[float] = None
    closed_loop: bool = False
    closed_loop_converged: bool = False
    closed_loop_passes: int = 0
    closed_loop_residual_um: float = 0.0
    closed_loop_unconverged_steps: int = 0
    peak_stress_mpa: float = 0.0
    stress_limit_mpa: float = 0.0
    steps: int = 0
    grid_mm: float = 0.0
    columns: int = 0
    shank_contact_steps: int = 0
    rapid_collision_steps: int = 0
    first_collision_line: Optional[int] = None
    warnings: List[Warning] = field(default_factory=list)
    columns_evaluated: int = 0
    sweep_time_s: float = 0.0
    tools: List[ToolPeaks] = field(default_factory=list)
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class SimulateSummary(Summary):
    """summary.json of ``dexcut simulate``: the run's numbers and the job,
    program, grid, set-up and run id."""

    schema_version: int = 0
    command: str = "simulate"
    job: str = ""
    program: str = ""
    exact_stop_time_s: Optional[float] = None
    grid: Optional[GridInfo] = None
    design: Optional[Dict[str, Any]] = None
    setup: Optional[Dict[str, Any]] = None
    run_time_s: float = 0.0
    run_id: str = ""


@dataclass(frozen=True)
class OptimizeSummary(_FromDict):
    """summary.json of ``optimize``: the program as given (``before``) and
    optimized.nc read back and simulated (``after``), the limits, the lower
    bound on the time and the timings."""

    schema_version: int = 0
    command: str = "optimize"
    job: str = ""
    program: str = ""
    grid: Optional[GridInfo] = None
    before: Optional[Summary] = None
    after: Optional[Summary] = None
    limits: Optional[Dict[str, Any]] = None
    cap_time_share: List[Dict[str, Any]] = field(default_factory=list)
    lower_bound_time_s: float = 0.0
    exact_stop_time_s: Optional[float] = None
    optimality_gap: float = 0.0
    stations: int = 0
    station_spacing_mm: float = 0.0
    peak_mrr_ratio: Optional[float] = None
    plan_time_s: float = 0.0
    time_optimal_s: float = 0.0
    written_vs_plan: float = 0.0
    rounds: int = 0
    merge_ratio: float = 0.0
    kept_original: bool = False
    fz_max_mm: Optional[float] = None
    design: Optional[Dict[str, Any]] = None
    setup: Optional[Dict[str, Any]] = None
    run_time_s: float = 0.0
    time_engagement_s: float = 0.0
    time_plan_s: float = 0.0
    time_simulate_s: float = 0.0
    run_id: str = ""
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class OperationLine(_FromDict):
    """One operation of a job of ``[[operations]]`` (:class:`OperationsSummary`):
    its results folder, program, cycle time (optimize: of the program written,
    ``cycle_time_before_s`` of the program as given), removal, peaks, error
    range and peaks per tool."""

    number: int = 0
    name: str = ""
    folder: str = ""
    program: str = ""
    cycle_time_s: float = 0.0
    cycle_time_before_s: Optional[float] = None
    kept_original: Optional[bool] = None
    removed_volume_mm3: float = 0.0
    peak_mrr_mm3_s: float = 0.0
    peak_force_n: float = 0.0
    peak_power_w: float = 0.0
    peak_deflection_um: float = 0.0
    min_error_um: Optional[float] = None
    max_error_um: Optional[float] = None
    warnings: int = 0
    tools: List[ToolPeaks] = field(default_factory=list)
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class OperationsSummary(_FromDict):
    """summary.json of a job of ``[[operations]]`` (``command`` "operations"):
    what each operation's folder holds (``ran``: "simulate" or "optimize"),
    the operations in order and the totals."""

    schema_version: int = 0
    command: str = "operations"
    ran: str = ""
    job: str = ""
    grid: Optional[GridInfo] = None
    operations: List[OperationLine] = field(default_factory=list)
    cycle_time_s: float = 0.0
    cycle_time_before_s: Optional[float] = None
    initial_volume_mm3: float = 0.0
    final_volume_mm3: float = 0.0
    removed_volume_mm3: float = 0.0
    saved_stock: Optional[str] = None
    run_time_s: float = 0.0
    run_id: str = ""
    _raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


def document(d: Dict[str, Any]):  # type: ignore[no-untyped-def]
    """The typed document of a summary.json dict, by its ``command``."""
    if d.get("command") == "operations":
        return OperationsSummary.from_dict(d)
    if d.get("command") == "optimize" or "after" in d:
        return OptimizeSummary.from_dict(d)
    return SimulateSummary.from_dict(d)
