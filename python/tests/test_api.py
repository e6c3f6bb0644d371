"""The Python API against the dexcut binary's files: the same arrays bit for
bit, the same summary values, exceptions by kind with the CLI's text, no
copy of the steps, the GIL released during a run."""
import json
import re
import shutil
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import dexcut
from conftest import REAL, ROOT, run_cli

SKIP = re.compile(r"^(run_id|run_time_s|time_.*|.*_wall_s|.*cpu_s|sweep_time_s|job|program|path|paths)$")


def norm(x):
    """summary.json without its timings, run id and input paths (scripts/cmp_outputs.py's rule)."""
    if isinstance(x, dict):
        return {k: norm(v) for k, v in x.items() if not SKIP.match(k)}
    if isinstance(x, list):
        return [norm(v) for v in x]
    return x


def same_array(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal dtype, shape and bytes (NaN equal to NaN of the same bits)."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


EXAMPLE = ROOT / "examples/boss_contour/job.toml"
PROGRAMS = [
    REAL / "fusion_tap_heatsink_drill.tap",
    REAL / "flatcam_kroneum_isolation_trimmed.nc",
    REAL / "freecad_corner_20_20_adaptive.nc",
]


@pytest.mark.parametrize("job", [EXAMPLE, *PROGRAMS], ids=lambda p: p.name)
def test_simulate_equals_the_cli_files(cli, tmp_path, job):
    out = tmp_path / "cli"
    run_cli(cli, "simulate", job, "--out", out, "--steps-format", "both")
    setup = dexcut.load(job)
    sim = dexcut.simulate(setup)
    # Steps: every array of the CLI's .npy form, bit for bit.
    table = json.loads((out / "steps.json").read_text())
    assert [c["name"] for c in table["columns"]] == list(sim.steps)
    for c in table["columns"]:
        assert same_array(sim.steps[c["name"]], np.load(out / c["file"])), c["name"]
    # The column grid, bit for bit, with its geometry.
    grid = json.loads((out / "columns.json").read_text())
    for a in grid["arrays"]:
        assert same_array(sim.columns[a["name"]], np.load(out / a["file"])), a["name"]
    assert sim.columns["error_um"].shape == (grid["ny"], grid["nx"])
    assert sim.x_mm[0] == grid["x0_mm"] and sim.y_mm[0] == grid["y0_mm"]
    assert len(sim.x_mm) == grid["nx"] and len(sim.y_mm) == grid["ny"]
    # The summary: every value of the run's part of summary.json.
    doc = json.loads((out / "summary.json").read_text())
    mine = sim.summary.to_dict()
    assert norm(mine) == norm({k: doc[k] for k in mine})
    assert sim.summary.peak_force_n == doc["peak_force_n"]
    assert [w.kind for w in sim.warnings] == [w["kind"] for w in doc["warnings"]]
    # The results folder read back: the same arrays from the .npy form and from steps.csv.
    res = dexcut.read_results(out)
    assert res.summary.command == "simulate" and res.summary.peak_force_n == doc["peak_force_n"]
    for name, arr in sim.steps.items():
        assert same_array(res.steps[name], arr), name
    (out / "steps.json").unlink()
    from_csv = dexcut.read_results(out).steps
    for name, arr in sim.steps.items():
        assert same_array(from_csv[name], arr), f"steps.csv {name}"


def test_simulation_writes_the_cli_files(cli, tmp_path):
    out = tmp_path / "cli"
    run_cli(cli, "simulate", EXAMPLE, "--out", out, "--steps-format", "npy")
    mine = tmp_path / "mine"
    mine.mkdir()
    sim = dexcut.simulate(dexcut.load(EXAMPLE))
    assert sim.write(mine, steps_format="npy") == "npy"
    for f in sorted(mine.iterdir()):
        assert f.read_bytes() == (out / f.name).read_bytes(), f.name


@pytest.mark.parametrize("job", [EXAMPLE, PROGRAMS[0]], ids=lambda p: p.name)
def test_optimize_equals_the_cli(cli, tmp_path, job):
    out = tmp_path / "cli"
    run_cli(cli, "optimize", job, "--out", out)
    opt = dexcut.optimize(dexcut.load(job), tmp_path / "py")
    doc = json.loads((out / "summary.json").read_text())
    assert norm(opt.summary.to_dict()) == norm(doc)
    assert opt.summary.after.cycle_time_s == doc["after"]["cycle_time_s"]
    assert opt.summary.before.peak_mrr_mm3_s == doc["before"]["peak_mrr_mm3_s"]
    if (out / "optimized.nc").exists():
        assert (tmp_path / "py/optimized.nc").read_bytes() == (out / "optimized.nc").read_bytes()
    res = opt.results()
    cli_res = dexcut.read_results(out)
    for stem in ("steps", "steps_before"):
        a, b = getattr(res, stem), getattr(cli_res, stem)
        assert a.keys() == b.keys()
        for name in a:
            assert same_array(a[name], b[name]), f"{stem} {name}"
    for name in res.columns:
        assert same_array(res.columns[name], cli_res.columns[name]), name


def test_steps_are_not_copied():
    sim = dexcut.simulate(dexcut.load(EXAMPLE))
    for name, arr in sim.steps.items():
        # The array owns no memory: its base is the Rust buffer's container, not an array.
        assert not arr.flags.owndata, name
        base = arr.base
        while isinstance(base, np.ndarray):
            base = base.base  # band_mm3 is a view reshaping the flat buffer
        assert base is not None and type(base).__name__ == "PySliceContainer", (name, type(base))
    assert not sim.columns["error_um"].flags.owndata


def test_the_gil_is_released_during_a_run():
    """A second thread, woken by the run's first progress call, answers
    while the run goes on: seen by a later progress call of the same run.
    With the GIL held by the run it could answer only when the run hands the
    GIL over, which with a 10 s switch interval it would not before its end."""
    setup = dexcut.load(EXAMPLE)
    inside, answered = threading.Event(), threading.Event()
    seen = []

    def progress(done, total, what):
        inside.set()
        seen.append(answered.is_set())

    def other():
        if inside.wait(timeout=120):
            answered.set()

    t = threading.Thread(target=other)
    old = sys.getswitchinterval()
    sys.setswitchinterval(10.0)
    try:
        t.start()
        started = time.perf_counter()
        sim = dexcut.simulate(setup, progress=progress)
        took = time.perf_counter() - started
    finally:
        sys.setswitchinterval(old)
        inside.set()
        t.join()
    assert sim.summary.steps > 0 and took < 10, took
    assert len(seen) >= 2 and seen[0] is False, seen
    assert any(seen), f"the other thread did not run during the run ({len(seen)} progress calls)"


def test_progress_reaches_the_callback():
    calls = []
    dexcut.simulate(dexcut.load(EXAMPLE), progress=lambda done, total, what: calls.append((done, total, what)))
    assert calls, "no progress"
    assert all(0 <= d <= t for d, t, _ in calls)
    assert any(d == t for d, t, _ in calls)


def bad_program_job(tmp_path: Path) -> Path:
    (tmp_path / "bad.nc").write_text("G21 G90\nG1 X10 F600\nG1 X20 Y5 Q\nM30\n")
    job = tmp_path / "job.toml"
    job.write_text(
        '[stock]\nkind = "box"\nmin = [0, -10, 0]\nmax = [30, 10, 5]\ngrid = 0.5\n'
        '[tool]\nkind = "flat"\ndiameter = 6\n[program]\npath = "bad.nc"\n'
    )
    return job


def test_a_program_error_carries_kind_line_column_and_the_cli_text(cli, tmp_path):
    job = bad_program_job(tmp_path)
    with pytest.raises(dexcut.ProgramError) as info:
        dexcut.load(job)
    e = info.value
    assert isinstance(e, dexcut.DexcutError)
    assert e.kind == "program"
    assert (e.line, e.column) == (3, e.diagnostics[0][2]) and e.line == e.diagnostics[0][1]
    assert e.column >= 1 and e.file.endswith("bad.nc")
    p = run_cli(cli, "simulate", job, "--out", tmp_path / "out", check=False)
    assert p.returncode == 1
    assert f"error: {e}" in p.stderr


def test_a_job_error_carries_kind_line_column_and_the_cli_text(cli, tmp_path):
    job = tmp_path / "job.toml"
    job.write_text('[stock]\nkind = "box"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\ngrid = 0.1\n[tool]\nkind = "ball"\ndiameter = \n')
    with pytest.raises(dexcut.JobError) as info:
        dexcut.load(job)
    e = info.value
    assert e.kind == "job" and e.line == 8 and e.column is not None
    p = run_cli(cli, "simulate", job, "--out", tmp_path / "out", check=False)
    assert f"error: {e}" in p.stderr
    with pytest.raises(dexcut.IoError) as io:
        dexcut.load(tmp_path / "missing.toml")
    assert io.value.kind == "io" and io.value.line is None


def test_report_and_evaluate(tmp_path):
    setup = dexcut.load(EXAMPLE)
    opt = dexcut.optimize(setup, tmp_path / "out")
    files = dexcut.report(opt.path)
    assert files.html.exists() and files.error_map_png.exists()
    ev = dexcut.evaluate(setup)
    assert ev.actual_mm.ndim == 2 and ev.actual_mm.shape[1] == 3
    assert ev.evaluation["trajectory_error_mm"] >= 0


def test_the_stubs_name_what_the_extension_has():
    import ast

    import dexcut._dexcut as ext

    stub = ast.parse((ROOT / "python/dexcut/_dexcut.pyi").read_text())
    stubbed = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    public = {n for n in dir(ext) if not n.startswith("_")}
    assert stubbed == public, (stubbed ^ public)


def test_read_results_of_a_job_of_operations(cli, tmp_path):
    """A job of [[operations]]'s folder reads back as an OperationsSummary
    with each operation's folder read back beside it."""
    out = tmp_path / "ops"
    job = ROOT / "examples/three_operations/job.toml"
    run_cli(cli, "simulate", job, "--out", out, "--grid", "0.5")
    res = dexcut.read_results(out)
    doc = json.loads((out / "summary.json").read_text())
    assert isinstance(res.summary, dexcut.OperationsSummary)
    assert res.summary.to_dict() == doc and res.summary.ran == "simulate"
    assert [op.folder for op in res.summary.operations] == [op["folder"] for op in doc["operations"]]
    assert res.summary.operations[0].tools[0].peak_force_n == doc["operations"][0]["tools"][0]["peak_force_n"]
    assert res.steps is None and list(res.operations) == [op["folder"] for op in doc["operations"]]
    grid = doc["grid"]
    assert res.columns["last_operation"].shape == (grid["ny"], grid["nx"])
    for op in doc["operations"]:
        one = res.operations[op["folder"]]
        op_doc = json.loads((out / op["folder"] / "summary.json").read_text())
        assert one.summary.command == "simulate" and one.summary.to_dict() == op_doc
        assert one.summary.removed_volume_mm3 == op["removed_volume_mm3"]
        assert one.steps is not None and len(one.steps["t_s"]) == op_doc["steps"]
    assert len(res.warnings) == sum(op["warnings"] for op in doc["operations"])
