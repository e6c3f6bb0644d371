#!/bin/bash
# Record LinuxCNC's commanded motion for one program, headless.
#   scripts/linuxcnc_reference/run.sh PROGRAM.nc OUT.txt [KEY=VALUE ...]
# The machine starts homed at X0 Y0 Z0. KEY=VALUE replaces every line
# `KEY = ...` of sim.ini (SERVO_PERIOD=1000000, MAX_LINEAR_ACCELERATION=500, ...).
# OUT.txt gets one line per servo period: x y z (µm) current_vel (mm/s) program_line.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
program="$(realpath "$1")"; out="$(realpath -m "$2")"
shift 2
work="$(mktemp -d /tmp/lcnc-ref.XXXXXX)"
trap 'rm -rf "$work"' EXIT
cp "$here/sim.hal" "$here/sim.tbl" "$work/"
sed "s|@DRIVER@|$here/driver.py|" "$here/sim.ini" > "$work/sim.ini"
for kv in "$@"; do
  k="${kv%%=*}"; v="${kv#*=}"
  sed -i "s|^$k = .*|$k = $v|" "$work/sim.ini"
done
rm -f "$out" "$out.failed" "$out.done"
# uspace's rtapi_app refuses to run as root unless told which user to become.
if [ "$(id -u)" = 0 ]; then export RTAPI_UID="${RTAPI_UID:-$(id -u nobody)}"; fi
export RTAPI_FIFO_PATH="${RTAPI_FIFO_PATH:-/tmp/.dexcut-rtapi-fifo}"
cd "$work"
# The linuxcnc script sends its output to files when stdin is not a terminal.
DEXCUT_PROGRAM="$program" DEXCUT_OUT="$out" PATH="/usr/bin:$PATH" \
  timeout "${DEXCUT_LCNC_TIMEOUT_S:-1900}" linuxcnc "$work/sim.ini" > "$work/log" 2>&1 || true
if [ -e "$out.failed" ] || [ ! -e "$out.done" ] || [ ! -s "$out" ]; then
  echo "run.sh: LinuxCNC failed on $program:" >&2
  cat "$out.failed" "$work/log" >&2 2>/dev/null || true
  tail -20 ~/linuxcnc_debug.txt >&2 2>/dev/null || true
  exit 1
fi
rm -f "$out.done"
