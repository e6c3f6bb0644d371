"""Batch runs of dexcut on Dask distributed: many independent jobs, one task
each.

``python -m dexcut batch simulate|optimize JOB_OR_PROGRAM... --out DIR``
runs each job file or G-code program (a folder stands for the jobs in it:
its ``.toml`` files, or where it has none its programs) as one task, on a
local cluster by default (``--workers``, one thread each: a run already uses
every core it is given through rayon, ``RAYON_NUM_THREADS``) or on the
cluster at ``--address``. ``--set limits.mrr_max=50,80,120`` (repeatable)
makes a sweep: every job × every combination of the values, one task each.

Each task writes its own results folder ``DIR/NAME`` whole (the library
stages it and swaps it in), then a record ``DIR/.batch/NAME.json`` naming
the hash of its inputs (the job's files' bytes, the command and its
parameters) and the results' run id. A task whose record matches its inputs
and whose folder holds every file its ``manifest.json`` lists, at its size,
is complete: a re-run skips it. A task that fails is reported in the index
and does not stop the others. ``DIR/index.csv`` (and ``index.parquet``
with pyarrow) lists every task: job, status, cycle before/after, peaks,
warnings, error.

Why Dask: pure-Python wheels (no service to install), ``LocalCluster`` with
a nanny that restarts a killed worker and reschedules its task, and the same
code on many machines through ``Client(address)``, started by
``dask scheduler``/``dask worker``, dask-jobqueue (Slurm, PBS) or
dask-kubernetes. See docs/guide/python.md.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import json
import os
import sys
import time
import uuid
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple

PROGRAM_SUFFIXES = {".nc", ".ngc", ".gcode", ".gc", ".tap", ".cnc", ".txt", ".ncc", ".nc1"}
RECORDS = ".batch"
COLUMNS = [
    "job",
    "input",
    "command",
    "status",
    "cycle_before_s",
    "cycle_after_s",
    "peak_mrr_before_mm3_s",
    "peak_mrr_after_mm3_s",
    "peak_force_before_n",
    "peak_force_after_n",
    "peak_deflection_before_um",
    "peak_deflection_after_um",
    "warnings",
    "error",
    "error_kind",
    "results",
    "wall_s",
]


# ---------------------------------------------------------------- the tasks


def expand_inputs(inputs: Sequence[str]) -> List[Path]:
    """Job files and programs; a folder gives its ``.toml`` jobs, or its
    programs where it has no job. Sorted, each once."""
    out: List[Path] = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            files = sorted(f for f in p.iterdir() if f.is_file())
            jobs = [f for f in files if f.suffix.lower() == ".toml"]
            out.extend(jobs or [f for f in files if f.suffix.lower() in PROGRAM_SUFFIXES])
        else:
            out.append(p)
    seen, unique = set(), []
    for p in out:
        key = os.path.abspath(p)
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique


def task_names(paths: Sequence[Path]) -> List[str]:
    """A folder name per input: the file's name without suffix (a
    ``job.toml`` by its folder's name), with as many of its folders before it
    (joined by ``__``) as make the names distinct."""
    parts = []
    for p in paths:
        a = Path(os.path.abspath(p))
        own = [x for x in a.parent.parts if x != a.anchor]
        if a.stem == "job" and own:
            parts.append((own[:-1], own[-1]))
        else:
            parts.append((own, a.stem))
    depth = 0
    while True:
        names = ["__".join(list(folders[len(folders) - depth :] if depth else []) + [stem]) for folders, stem in parts]
        if len(set(names)) == len(names) or depth > max(len(f) for f, _ in parts):
            return names
        depth += 1


def parse_set(items: Sequence[str]) -> List[Tuple[str, List[float]]]:
    """``--set KEY=V1,V2,...`` options as (key, values)."""
    grid = []
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip():
            raise SystemExit(f"--set {item!r}: give SECTION.KEY=V1,V2,... (e.g. limits.mrr_max=50,80,120)")
        try:
            grid.append((key.strip(), [float(v) for v in values.split(",") if v.strip()]))
        except ValueError as e:
            raise SystemExit(f"--set {item!r}: {e}") from None
    return grid


def _fmt(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else repr(float(v))


def _job_doc(path: Path) -> Dict[str, Any]:
    """The job file's TOML, or {} where it does not read (the run tells why)."""
    try:
        import tomllib  # type: ignore[import-not-found]
    except ImportError:  # Python < 3.11
        import tomli as tomllib  # type: ignore[import-not-found,no-redef]
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except Exception:  # the job's own error comes from the run
        return {}


def _refuse_operation_keys(path: Path, sweep: Sequence[Tuple[str, List[float]]]) -> None:
    """A sweep's key that a job of ``[[operations]]`` gives per operation
    (every operation has its tool; ``[operations.limits]`` and the like)
    would change the job's table, which those operations do not read."""
    ops = _job_doc(path).get("operations")
    if not isinstance(ops, list) or not ops:
        return
    for key, _ in sweep:
        section = key.split(".")[0]
        if section in ("tool", "tools") or any(isinstance(op, dict) and section in op for op in ops):
            raise SystemExit(
                f"--set {key}: {path} is a job of [[operations]] whose operations give their own [{section}]; "
                "sweep a job of one operation instead"
            )


def _job_inputs(path: Path) -> List[Path]:
    """The files a job file reads (program, stock mesh, design model, each operation's program)."""
    doc = _job_doc(path)
    files = []
    for section in ("program", "stock", "design"):
        t = doc.get(section)
        if isinstance(t, dict) and isinstance(t.get("path"), str):
            files.append(path.parent / t["path"])
    # A job of [[operations]]: each its program (a path, or a table with one).
    for op in doc.get("operations", []) if isinstance(doc.get("operations"), list) else []:
        prog = op.get("program") if isinstance(op, dict) else None
        if isinstance(prog, dict):
            prog = prog.get("path")
        if isinstance(prog, str):
            files.append(path.parent / prog)
    return files


def _hash_files(h: "hashlib._Hash", files: Iterable[Path]) -> None:
    expanded: List[Path] = []
    for f in files:
        # A folder (a saved stock, `[stock] kind = "saved"`): every file in it.
        expanded.extend(sorted(x for x in Path(f).rglob("*") if x.is_file()) if Path(f).is_dir() else [Path(f)])
    for f in expanded:
        h.update(str(os.path.abspath(f)).encode())
        try:
            with open(f, "rb") as fh:
                for block in iter(lambda: fh.read(1 << 20), b""):
                    h.update(block)
        except OSError as e:
            h.update(f"unreadable: {e}".encode())


def make_tasks(
    command: str,
    inputs: Sequence[str],
    out: Path,
    grid: Optional[float] = None,
    tool: Optional[str] = None,
    steps_format: str = "auto",
    sweep: Sequence[Tuple[str, List[float]]] = (),
) -> List[Dict[str, Any]]:
    """One task per input (× every combination of the sweep's values)."""
    from . import _dexcut

    paths = expand_inputs(inputs)
    names = task_names(paths)
    combos: List[Tuple[Tuple[str, float], ...]] = [()]
    if sweep:
        combos = [tuple(zip([k for k, _ in sweep], vs)) for vs in itertools.product(*[v for _, v in sweep])]
    tasks = []
    for path, name in zip(paths, names):
        is_job = _dexcut.is_job_file(path)
        files = [path] + (_job_inputs(path) if is_job else [])
        if is_job and sweep:
            _refuse_operation_keys(path, sweep)
        for combo in combos:
            task_name = name
            if combo:
                task_name += "__" + ",".join(f"{k.split('.')[-1]}={_fmt(v)}" for k, v in combo)
            h = hashlib.sha256()
            h.update(
                json.dumps(
                    [_dexcut.__version__, command, grid, tool, steps_format, [list(c) for c in combo]]
                ).encode()
            )
            _hash_files(h, files)
            tasks.append(
                {
                    "name": task_name,
                    "command": command,
                    "input": str(path),
                    "is_job": is_job,
                    "out": str(out / task_name),
                    "records": str(out / RECORDS),
                    "grid": grid,
                    "tool": tool,
                    "steps_format": steps_format,
                    "overrides": [list(c) for c in combo],
                    "key": h.hexdigest(),
                }
            )
    seen = set()
    for t in tasks:
        if t["name"] in seen:
            raise SystemExit(f"two tasks would write {t['out']}: give inputs with distinct names")
        seen.add(t["name"])
    return tasks


def is_complete(task: Dict[str, Any]) -> Optional[Dict[str, Any]]:
    """The task's record if its results are complete for these inputs: the
    record's input hash is the task's, the folder's manifest has the
    record's run id, and every file the manifest lists is there at its size."""
    record_path = Path(task["records"]) / f"{task['name']}.json"
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
        if record.get("key") != task["key"] or record.get("row", {}).get("status") != "ok":
            return None
        out = Path(task["out"])
        manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
        if manifest.get("run_id") != record.get("run_id"):
            return None
        for name, size in manifest.get("files", {}).items():
            if (out / name).stat().st_size != size:
                return None
        return record
    except (OSError, ValueError):
        return None


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _row(task: Dict[str, Any], summary: Optional[Dict[str, Any]]) -> Dict[str, Any]:
    row: Dict[str, Any] = {c: None for c in COLUMNS}
    row.update(job=task["name"], input=task["input"], command=task["command"], results=task["out"])
    for key, value in task["overrides"]:
        row[key] = value
    if summary is None:
        return row
    if summary.get("command") == "operations":
        return _operations_row(row, summary)
    if summary.get("command") == "optimize":
        before, after = summary["before"], summary["after"]
    else:
        before, after = summary, None
    row["cycle_before_s"] = before["cycle_time_s"]
    row["peak_mrr_before_mm3_s"] = before["peak_mrr_mm3_s"]
    row["peak_force_before_n"] = before["peak_force_n"]
    row["peak_deflection_before_um"] = before["peak_deflection_um"]
    if after is not None:
        row["cycle_after_s"] = after["cycle_time_s"]
        row["peak_mrr_after_mm3_s"] = after["peak_mrr_mm3_s"]
        row["peak_force_after_n"] = after["peak_force_n"]
        row["peak_deflection_after_um"] = after["peak_deflection_um"]
    row["warnings"] = len((after or before)["warnings"])
    return row


def _operations_row(row: Dict[str, Any], summary: Dict[str, Any]) -> Dict[str, Any]:
    """A job of ``[[operations]]``: the cycle times summed (optimize: as
    given and written), the peaks the highest of any operation (optimize:
    of the programs written, so in the ``after`` columns), the warnings
    summed."""
    ops = summary["operations"]
    side = "after" if summary.get("ran") == "optimize" else "before"
    if side == "after":
        row["cycle_before_s"] = summary.get("cycle_time_before_s")
        row["cycle_after_s"] = summary["cycle_time_s"]
    else:
        row["cycle_before_s"] = summary["cycle_time_s"]
    for column, key in (("peak_mrr", "peak_mrr_mm3_s"), ("peak_force", "peak_force_n"), ("peak_deflection", "peak_deflection_um")):
        values = [op[key] for op in ops if op.get(key) is not None]
        unit = key[len(column) :]
        row[f"{column}_{side}{unit}"] = max(values) if values else None
    row["warnings"] = sum(int(op.get("warnings") or 0) for op in ops)
    return row


def run_task(task: Dict[str, Any]) -> Dict[str, Any]:
    """Run one task where it is scheduled (a Dask worker, or this process):
    its results folder, then its record; a task already complete returns
    its record's row (``skipped``). Never raises: a failure is the row's
    status ``error`` with the exception's kind and message."""
    from . import _dexcut

    # Complete already: Dask runs a task again when the worker holding its
    # result died before the result was gathered; the results on disk stand.
    record = is_complete(task)
    if record is not None:
        row = dict(record["row"])
        row["skipped"] = True
        return row
    started = time.perf_counter()
    row = _row(task, None)
    try:
        job_text = None
        path = Path(task["input"])
        if task["overrides"]:
            if task["is_job"]:
                text, base = path.read_text(encoding="utf-8"), path.parent.resolve()
            else:
                text, _ = _dexcut.fit_job(path, task["tool"], task["grid"])
                base = Path("/")
            job_text = _dexcut.job_variant(text, str(path), base, [tuple(o) for o in task["overrides"]])
        _dexcut.run_command(
            task["command"],
            path,
            Path(task["out"]),
            task["grid"],
            None if task["is_job"] else task["tool"],
            False,
            task["steps_format"],
            job_text,
            None,
        )
        out = Path(task["out"])
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
        row = _row(task, summary)
        row["status"] = "ok"
        row["wall_s"] = time.perf_counter() - started
        record = {"key": task["key"], "run_id": manifest["run_id"], "row": row}
        _write_atomic(Path(task["records"]) / f"{task['name']}.json", json.dumps(record, indent=1))
    except Exception as e:  # reported in the index; the other tasks go on
        row["status"] = "error"
        row["error"] = str(e)
        row["error_kind"] = getattr(e, "kind", type(e).__name__)
        row["wall_s"] = time.perf_counter() - started
    return row


# ---------------------------------------------------------------- the batch


def write_index(out: Path, rows: List[Dict[str, Any]], sweep_keys: Sequence[str] = ()) -> List[Path]:
    """``index.csv`` (and ``index.parquet`` where pyarrow is installed),
    one row per task in the order given; returns the files written."""
    columns = COLUMNS[:2] + list(sweep_keys) + COLUMNS[2:]
    out.mkdir(parents=True, exist_ok=True)
    written = []
    tmp = out / f".index.csv.{os.getpid()}.tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: ("" if r.get(c) is None else r.get(c)) for c in columns})
    os.replace(tmp, out / "index.csv")
    written.append(out / "index.csv")
    try:
        import pyarrow as pa  # type: ignore[import-not-found]
        import pyarrow.parquet as pq  # type: ignore[import-not-found]
    except ImportError:
        return written
    text = {"job", "input", "command", "status", "error", "error_kind", "results"}
    arrays = {}
    for c in columns:
        values = [r.get(c) for r in rows]
        if c in text:
            arrays[c] = pa.array(values, type=pa.string())
        elif c == "warnings":
            arrays[c] = pa.array(values, type=pa.int64())
        else:
            arrays[c] = pa.array([None if v is None else float(v) for v in values], type=pa.float64())
    tmp = out / f".index.parquet.{os.getpid()}.tmp"
    pq.write_table(pa.table(arrays), tmp)
    os.replace(tmp, out / "index.parquet")
    written.append(out / "index.parquet")
    return written


def run_batch(
    command: str,
    inputs: Sequence[str],
    out: "os.PathLike[str] | str",
    address: Optional[str] = None,
    workers: int = 2,
    grid: Optional[float] = None,
    tool: Optional[str] = None,
    steps_format: str = "auto",
    sweep: Sequence[Tuple[str, List[float]]] = (),
    client: Any = None,
    log=print,  # type: ignore[no-untyped-def]
) -> List[Dict[str, Any]]:
    """Run every task on Dask (``client``, else the cluster at ``address``,
    else a local cluster of ``workers`` processes), skipping complete ones;
    write the index; return its rows."""
    out = Path(out)
    tasks = make_tasks(command, inputs, out, grid, tool, steps_format, sweep)
    rows: List[Dict[str, Any]] = []
    todo = []
    for t in tasks:
        record = is_complete(t)
        if record is None:
            todo.append(t)
        else:
            row = dict(record["row"])
            row["status"] = "ok"
            row["skipped"] = True
            rows.append(row)
    log(f"{len(tasks)} task(s): {len(tasks) - len(todo)} complete, {len(todo)} to run")
    if todo:
        rows.extend(_run_on_dask(todo, address, workers, client, log))
    order = {t["name"]: i for i, t in enumerate(tasks)}
    rows.sort(key=lambda r: order[r["job"]])
    write_index(out, rows, [k for k, _ in sweep])
    failed = sum(1 for r in rows if r["status"] != "ok")
    log(f"{len(rows) - failed} ok, {failed} failed: {out / 'index.csv'}")
    return rows


def _run_on_dask(todo, address, workers, client, log):  # type: ignore[no-untyped-def]
    from dask.distributed import Client, LocalCluster, as_completed  # type: ignore[import-not-found]

    own = None
    if client is None:
        if address:
            client = own = Client(address)
        else:
            cluster = LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
            )
            client = own = Client(cluster)
    try:
        # A key of this submission: a scheduler keeps an erred task's key
        # while a client holds it, and a re-run on the same client given the
        # same key would get the old failure back instead of a run.
        run = uuid.uuid4().hex[:12]
        futures = {client.submit(run_task, t, key=f"dexcut-{t['name']}-{run}", pure=False): t for t in todo}
        rows = []
        for future in as_completed(futures):
            t = futures[future]
            try:
                row = future.result()
            except Exception as e:  # a worker lost more often than Dask retries
                record = is_complete(t)
                if record is not None:
                    # It finished (results and record written) before its worker died.
                    row = dict(record["row"])
                else:
                    row = _row(t, None)
                    row.update(status="error", error=f"{type(e).__name__}: {e}", error_kind="worker")
            rows.append(row)
            log(f"  {row['status']:5} {row['job']}" + (f": {row['error']}" if row["error"] else ""))
        return rows
    finally:
        if own is not None:
            cluster = getattr(own, "cluster", None)
            own.close()
            if cluster is not None and not address:
                cluster.close()


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m dexcut batch",
        description="Run simulate or optimize on many jobs or programs as independent Dask tasks.",
    )
    p.add_argument("command", choices=["simulate", "optimize"])
    p.add_argument("inputs", nargs="+", metavar="JOB_OR_PROGRAM", help="job files, G-code programs or folders of them")
    p.add_argument("--out", required=True, help="folder of the results: one folder per task, index.csv, index.parquet")
    p.add_argument("--address", help="a Dask scheduler (tcp://host:8786); default: a local cluster")
    p.add_argument("--workers", type=int, default=2, help="local cluster's worker processes (default 2)")
    p.add_argument("--grid", type=float, help="column spacing, mm (as --grid of the CLI)")
    p.add_argument("--tool", help="tool of programs given without a job: flat:6, ball:3.175, bull:10:1")
    p.add_argument("--steps-format", default="auto", choices=["auto", "csv", "npy", "both"])
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=V1,V2,...",
        help="sweep a job key over values (repeat for a grid): limits.mrr_max, tool.stickout, machine.accel, ...",
    )
    a = p.parse_args(argv)
    rows = run_batch(
        a.command,
        a.inputs,
        a.out,
        address=a.address,
        workers=a.workers,
        grid=a.grid,
        tool=a.tool,
        steps_format=a.steps_format,
        sweep=parse_set(a.set),
    )
    return 0 if all(r["status"] == "ok" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
