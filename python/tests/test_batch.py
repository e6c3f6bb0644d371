"""Batch runs on a local Dask cluster: the same summaries as serial CLI
runs, a killed worker loses no finished result and a re-run completes the
rest, and the sweep form's table."""
import csv
import json
import os
import signal
import threading
import time

import pytest

from conftest import REAL, ROOT, run_cli
from test_api import norm

distributed = pytest.importorskip("dask.distributed")
from dexcut import batch  # noqa: E402

# 20 real programs of other CAM systems that fit a job from their comments
# and simulate in well under a second each.
PROGRAMS = [
    REAL / n
    for n in [
        "estlcam11_ps2cnc_004.nc",
        "freecad_hole_7mm_adaptive.nc",
        "fusion_tap_heatsink_drill.tap",
        "fusion_led_floor_block.nc",
        "pcb2gcode_milldrill.ngc",
        "openbuilds_cam_ps2cnc_004.nc",
        "fusion_linuxcnc_kroneum_usb_holes.nc",
        "pcb2gcode_outline.ngc",
        "fusion_led_floor_1022_block2x2_17bit.nc",
        "estlcam_spool_fixture.nc",
        "freecad_corner_20_20_adaptive.nc",
        "flatcam_kroneum_isolation_trimmed.nc",
        "fusion_led_floor_light_holes.nc",
        "fusion_tap_heatsink_mill_trimmed.tap",
        "fusion_led_floor_1072_face_otherside.nc",
        "pcb2gcode_drill.ngc",
        "freecad_plate8_profile.nc",
        "flatcam_kroneum_cutout.nc",
        "sketchucam_arc_rword_test.gcode",
        "drl2gcode_kicad_T02.gcode",
    ]
]


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def summaries(folder):
    return norm(json.loads((folder / "summary.json").read_text()))


def test_twenty_jobs_on_two_workers_equal_twenty_serial_cli_runs(cli, client, tmp_path):
    serial = tmp_path / "serial"
    started = time.perf_counter()
    for p in PROGRAMS:
        run_cli(cli, "simulate", p, "--out", serial / p.stem)
    serial_s = time.perf_counter() - started
    out = tmp_path / "batch"
    started = time.perf_counter()
    rows = batch.run_batch("simulate", [str(p) for p in PROGRAMS], out, client=client, log=lambda *_: None)
    batch_s = time.perf_counter() - started
    print(f"20 serial CLI runs {serial_s:.2f} s, batch on 2 workers {batch_s:.2f} s")
    assert len(rows) == 20 and all(r["status"] == "ok" for r in rows), [r["error"] for r in rows]
    for p in PROGRAMS:
        a, b = serial / p.stem, out / p.stem
        assert summaries(b) == summaries(a), p.name
        for f in sorted(a.iterdir()):
            if f.is_file() and f.name not in ("summary.json", "manifest.json"):
                assert (b / f.name).read_bytes() == f.read_bytes(), (p.name, f.name)
    index = (out / "index.csv").read_text().splitlines()
    assert len(index) == 21 and index[0].startswith("job,input,command,status,cycle_before_s")
    import pyarrow.parquet as pq

    table = pq.read_table(out / "index.parquet").to_pylist()
    assert [r["job"] for r in table] == [r["job"] for r in rows]
    assert [r["cycle_before_s"] for r in table] == [
        json.loads((serial / p.stem / "summary.json").read_text())["cycle_time_s"] for p in PROGRAMS
    ]


def _allowed_failures(n, dask_scheduler=None):
    old = dask_scheduler.allowed_failures
    dask_scheduler.allowed_failures = n
    return old


def _records(out):
    records = out / batch.RECORDS
    return len(list(records.glob("*.json"))) if records.exists() else 0


def _kill_a_busy_worker(client):
    """SIGKILL a worker that is running a task; returns its pid and the keys it was running."""
    for addr, keys in client.processing().items():
        if keys:
            pid = client.run(os.getpid, workers=[addr])[addr]
            os.kill(pid, signal.SIGKILL)
            return pid, keys
    raise AssertionError("no worker is running a task")


def test_a_killed_worker_loses_no_finished_result_and_a_rerun_completes_the_rest(client, tmp_path):
    out = tmp_path / "batch"
    inputs = [str(p) for p in PROGRAMS]
    tasks = batch.make_tasks("simulate", inputs, out)
    # Dask runs a killed worker's task again elsewhere (allowed-failures, 3 by
    # default: see the next test); with none allowed, the task the worker was
    # running fails, so that the first run leaves work for the re-run.
    old = client.run_on_scheduler(_allowed_failures, 0)
    done = {}
    thread = threading.Thread(
        target=lambda: done.setdefault("rows", batch.run_batch("simulate", inputs, out, client=client, log=lambda *_: None))
    )
    try:
        thread.start()
        deadline = time.time() + 120
        while time.time() < deadline and _records(out) < 3:
            time.sleep(0.002)
        finished = {t["name"]: batch.is_complete(t) for t in tasks}
        finished = {name: rec for name, rec in finished.items() if rec is not None}
        victim, running = _kill_a_busy_worker(client)
        thread.join(timeout=300)
    finally:
        client.run_on_scheduler(_allowed_failures, old)
    assert 3 <= len(finished) < 20, len(finished)
    assert "rows" in done
    first = {r["job"]: r for r in done["rows"]}
    lost = {j for j, r in first.items() if r["status"] != "ok"}
    print(f"killed worker {victim} running {running} after {len(finished)} results; first run: {20 - len(lost)} ok, lost {sorted(lost)}")
    # The task the killed worker ran is reported as lost, not as a result
    # (one it had finished, results and record written, before it died is ok).
    assert lost and all(first[j]["error_kind"] == "worker" and "KilledWorker" in first[j]["error"] for j in lost), lost
    assert not lost & set(finished)
    assert lost == {t["name"] for t in tasks if batch.is_complete(t) is None}
    assert [r["status"] for r in csv.DictReader((out / "index.csv").open())].count("error") == len(lost)
    # The re-run skips every finished task (nothing finished before the kill
    # was lost or redone: the same run ids) and runs exactly the lost ones.
    client.wait_for_workers(2, timeout=60)
    rows = batch.run_batch("simulate", inputs, out, client=client, log=lambda *_: None)
    assert all(r["status"] == "ok" for r in rows), [r["error"] for r in rows]
    ran = {r["job"] for r in rows if not r.get("skipped")}
    assert ran == lost, (ran, lost)
    for t in tasks:
        record = batch.is_complete(t)
        assert record is not None, t["name"]
        if t["name"] in finished:
            assert record["run_id"] == finished[t["name"]]["run_id"], t["name"]
    # No staging folder or pending file of the killed run is left.
    assert sorted(p.name for p in out.iterdir()) == sorted([t["name"] for t in tasks] + [batch.RECORDS, "index.csv", "index.parquet"])
    # An input changed: its task is no longer complete.
    changed = tmp_path / "changed.nc"
    changed.write_bytes(PROGRAMS[0].read_bytes())
    t = batch.make_tasks("simulate", [str(changed)], out)[0]
    assert batch.is_complete(t) is None


def test_a_killed_workers_task_runs_again_elsewhere(client, tmp_path):
    out = tmp_path / "batch"
    inputs = [str(p) for p in PROGRAMS[:8]]
    done = {}
    thread = threading.Thread(
        target=lambda: done.setdefault("rows", batch.run_batch("simulate", inputs, out, client=client, log=lambda *_: None))
    )
    thread.start()
    deadline = time.time() + 120
    while time.time() < deadline and _records(out) < 1:
        time.sleep(0.002)
    _kill_a_busy_worker(client)
    thread.join(timeout=300)
    # With Dask's default retries the batch finishes whole.
    assert [r["status"] for r in done["rows"]] == ["ok"] * 8, [r["error"] for r in done["rows"]]
    client.wait_for_workers(2, timeout=60)


def test_a_sweep_of_three_by_three_values_returns_its_table(client, tmp_path):
    job = ROOT / "examples/boss_contour/job.toml"
    sweep = [("limits.mrr_max", [5.0, 10.0, 20.0]), ("tool.stickout", [25.0, 30.0, 35.0])]
    rows = batch.run_batch("optimize", [str(job)], tmp_path / "sweep", sweep=sweep, client=client, log=lambda *_: None)
    assert len(rows) == 9 and all(r["status"] == "ok" for r in rows), [r["error"] for r in rows]
    assert [(r["limits.mrr_max"], r["tool.stickout"]) for r in rows] == [
        (m, s) for m in (5.0, 10.0, 20.0) for s in (25.0, 30.0, 35.0)
    ]
    by = {(r["limits.mrr_max"], r["tool.stickout"]): r for r in rows}
    for s in (25.0, 30.0, 35.0):
        # A higher removal-rate limit never makes the program slower; each run keeps its limit.
        assert by[(5.0, s)]["cycle_after_s"] >= by[(10.0, s)]["cycle_after_s"] >= by[(20.0, s)]["cycle_after_s"]
        for m in (5.0, 10.0, 20.0):
            assert by[(m, s)]["peak_mrr_after_mm3_s"] <= 1.02 * m
    for m in (5.0, 10.0, 20.0):
        # A longer stickout deflects more under the same limit.
        assert by[(m, 25.0)]["peak_deflection_after_um"] < by[(m, 35.0)]["peak_deflection_after_um"]
    # Each task's job is the variant, written with its results.
    text = (tmp_path / "sweep/boss_contour__mrr_max=10,stickout=30/input/job.toml").read_text()
    assert "mrr_max = 10" in text and "stickout = 30" in text
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "sweep/index.parquet").to_pydict()
    assert table["limits.mrr_max"] == [r["limits.mrr_max"] for r in rows]
    assert table["cycle_after_s"] == [r["cycle_after_s"] for r in rows]


def test_the_command_reports_a_failed_job_and_runs_the_others(cli, tmp_path):
    import subprocess
    import sys

    from test_api import bad_program_job

    (tmp_path / "bad").mkdir()
    bad = bad_program_job(tmp_path / "bad")
    inputs = [str(PROGRAMS[0]), str(bad), str(PROGRAMS[2])]
    out = tmp_path / "out"
    p = subprocess.run(
        [sys.executable, "-m", "dexcut", "batch", "simulate", *inputs, "--out", str(out), "--workers", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 1, p.stderr
    rows = list(csv.DictReader((out / "index.csv").open()))
    assert [r["status"] for r in rows] == ["ok", "error", "ok"], rows
    # The failed job's row has its kind and the CLI's message.
    cli_run = run_cli(cli, "simulate", bad, "--out", tmp_path / "cli", check=False)
    assert rows[1]["error_kind"] == "program" and f"error: {rows[1]['error']}" in cli_run.stderr
    for r, prog in ((rows[0], PROGRAMS[0]), (rows[2], PROGRAMS[2])):
        run_cli(cli, "simulate", prog, "--out", tmp_path / "cli" / prog.stem)
        assert summaries(out / r["job"]) == summaries(tmp_path / "cli" / prog.stem)


def test_a_job_of_operations_is_one_task_with_the_cli_results(cli, client, tmp_path):
    import shutil

    src = ROOT / "examples/three_operations"
    job = tmp_path / "three_operations/job.toml"
    shutil.copytree(src, job.parent)
    run_cli(cli, "simulate", job, "--out", tmp_path / "cli")
    out = tmp_path / "batch"
    rows = batch.run_batch("simulate", [str(job)], out, client=client, log=lambda *_: None)
    assert [r["status"] for r in rows] == ["ok"], rows
    doc = json.loads((tmp_path / "cli/summary.json").read_text())
    assert doc["command"] == "operations" and len(doc["operations"]) == 3
    got = out / "three_operations"
    assert summaries(got) == summaries(tmp_path / "cli")
    for op in doc["operations"]:
        assert summaries(got / op["folder"]) == summaries(tmp_path / "cli" / op["folder"]), op["folder"]
    row = rows[0]
    assert row["cycle_before_s"] == doc["cycle_time_s"]
    assert row["peak_force_before_n"] == max(op["peak_force_n"] for op in doc["operations"])
    assert row["warnings"] == sum(op["warnings"] for op in doc["operations"])
    # Complete, and no longer so when one operation's program changes.
    task = batch.make_tasks("simulate", [str(job)], out)[0]
    assert batch.is_complete(task) is not None
    finish = job.parent / "finish.nc"
    finish.write_text(finish.read_text() + "\n")
    assert batch.is_complete(batch.make_tasks("simulate", [str(job)], out)[0]) is None


def test_a_sweep_refuses_keys_the_operations_give_their_own(tmp_path):
    job = ROOT / "examples/three_operations/job.toml"
    for key in ("tool.stickout", "limits.mrr_max"):
        with pytest.raises(SystemExit, match=r"\[\[operations\]\] whose operations give their own"):
            batch.make_tasks("optimize", [str(job)], tmp_path, sweep=[(key, [1.0, 2.0])])
    # A key no operation overrides is swept as for a job of one program.
    assert len(batch.make_tasks("simulate", [str(job)], tmp_path, sweep=[("cutting.band_height", [0.5, 1.0])])) == 2
