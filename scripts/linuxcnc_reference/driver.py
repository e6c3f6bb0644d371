#!/usr/bin/python3
"""LinuxCNC "display" that records one program's motion without a screen.

LinuxCNC starts it as `driver.py -ini FILE` once HAL and motion run. It reads
the program and the output file from the environment
(run.sh sets them), leaves E-stop, homes every joint (HOME_SEARCH_VEL = 0:
homed where they stand, at 0), then enables the
HAL sampler, runs the program in AUTO, waits for it to finish, and writes the
samples: one line per servo period, `x y z` (µm) `current_vel` (mm/s) `program_line`.
"""
import os
import subprocess
import sys
import time

import linuxcnc


def wait(stat, done, what, timeout_s=600.0):
    t0 = time.time()
    while True:
        stat.poll()
        if done(stat):
            return
        if time.time() - t0 > timeout_s:
            raise SystemExit(f"driver: timed out waiting for {what}")
        time.sleep(0.01)


def check_error(err):
    e = err.poll()
    if e:
        kind, text = e
        if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
            raise SystemExit(f"driver: LinuxCNC error: {text}")
        print(f"driver: LinuxCNC message: {text}", file=sys.stderr)


def main():
    program = os.environ["DEXCUT_PROGRAM"]
    out = os.environ["DEXCUT_OUT"]
    s, c, err = linuxcnc.stat(), linuxcnc.command(), linuxcnc.error_channel()
    wait(s, lambda s: s.task_state is not None, "task")
    c.state(linuxcnc.STATE_ESTOP_RESET)
    c.state(linuxcnc.STATE_ON)
    wait(s, lambda s: s.task_state == linuxcnc.STATE_ON, "machine on")
    c.mode(linuxcnc.MODE_MANUAL)
    c.wait_complete()
    c.home(-1)
    c.wait_complete()
    wait(s, lambda s: all(s.homed[: s.joints]), "homing")
    check_error(err)
    time.sleep(0.1)
    sampler = subprocess.Popen(["halsampler", "-c", "0"], stdout=open(out, "w"))
    subprocess.run(["halcmd", "setp", "sampler.0.enable", "1"], check=True)
    c.mode(linuxcnc.MODE_AUTO)
    c.wait_complete()
    c.program_open(program)
    c.wait_complete()
    c.auto(linuxcnc.AUTO_RUN, 0)
    time.sleep(0.2)
    t0 = time.time()
    while True:
        s.poll()
        check_error(err)
        if s.interp_state == linuxcnc.INTERP_IDLE and s.queue == 0 and s.inpos:
            break
        if time.time() - t0 > 1800:
            raise SystemExit("driver: program did not finish in 30 min")
        time.sleep(0.02)
    time.sleep(0.2)
    subprocess.run(["halcmd", "setp", "sampler.0.enable", "0"], check=True)
    time.sleep(0.5)
    sampler.terminate()
    sampler.wait()
    overruns = subprocess.run(
        ["halcmd", "getp", "sampler.0.overruns"], capture_output=True, text=True
    ).stdout.strip()
    print(f"driver: done, sampler overruns {overruns}", file=sys.stderr)
    if overruns not in ("0", ""):
        raise SystemExit(f"driver: the sampler lost samples ({overruns} overruns)")
    c.state(linuxcnc.STATE_OFF)
    open(os.environ["DEXCUT_OUT"] + ".done", "w").write("ok\n")


if __name__ == "__main__":
    try:
        main()
    except SystemExit as e:
        print(e, file=sys.stderr)
        open(os.environ["DEXCUT_OUT"] + ".failed", "w").write(str(e) + "\n")
        raise
