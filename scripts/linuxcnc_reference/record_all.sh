#!/bin/bash
# Regenerate crates/schedule/tests/data/linuxcnc_reference/ from the real LinuxCNC:
#   scripts/linuxcnc_reference/record_all.sh [NAME ...]
# (all programs when no name is given). Needs linuxcnc-uspace; takes about the
# programs' machine time (the servo thread runs in real time).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
data="$root/crates/schedule/tests/data/linuxcnc_reference"
cd "$root"
python3 scripts/linuxcnc_reference/make_programs.py
period_ns=$(sed -n 's/^SERVO_PERIOD = //p' scripts/linuxcnc_reference/sim.ini)
names=("$@")
if [ ${#names[@]} = 0 ]; then
  names=($(cd "$data/programs" && ls *.ngc | sed 's/\.ngc$//'))
fi
raw="$(mktemp -d /tmp/lcnc-raw.XXXXXX)"
trap 'rm -rf "$raw"' EXIT
for n in "${names[@]}"; do
  t0=$(date +%s)
  scripts/linuxcnc_reference/run.sh "$data/programs/$n.ngc" "$raw/$n.txt"
  python3 scripts/linuxcnc_reference/pack.py "$raw/$n.txt" "$data/$n.txt.gz" "$n" "$period_ns"
  echo "$n: $(( $(date +%s) - t0 )) s, $(zcat "$data/$n.txt.gz" | sed -n 's/^samples //p') samples"
done
