#!/usr/bin/env bash
# Times dexcut binaries side by side: each job run by each binary in turn, two
# rounds (3D_Chips one), so that the host's drift falls on all of them alike.
# One line a run: job, binary, wall seconds, peak RSS in kB (GNU time).
#
# Usage: scripts/interleave_times.sh BENCH_DIR OUT_FILE BIN...
#   BENCH_DIR from `cargo run --release -p dexcut --example bench_programs -- BENCH_DIR`
#   e.g. scripts/interleave_times.sh /tmp/bench /tmp/times.txt /tmp/old/dexcut target/release/dexcut
set -u
bench=$(realpath "$1"); out=$(realpath -m "$2"); shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
R=$root/crates/nc/tests/data/real
export CI=1
scratch=$(mktemp -d)
jobs=(
    "raster:simulate $bench/raster_csv.toml"
    "m1:simulate $bench/finish_1m_ngc.toml"
    "blender:optimize $R/blendercam_MedialPocket.gcode --tool flat:3"
    "chips:optimize $root/examples/3d_chips/job.toml"
    "estlcam:optimize $R/estlcam_backplate.nc --tool flat:3"
)
for round in 1 2; do
    for spec in "${jobs[@]}"; do
        name=${spec%%:*}; args=${spec#*:}
        [ "$round" = 2 ] && [ "$name" = chips ] && continue
        i=0
        for bin in "$@"; do
            i=$((i + 1))
            # shellcheck disable=SC2086
            /usr/bin/time -f "%e %M" -o "$scratch/t" "$bin" $args --out "$scratch/out$i" >/dev/null 2>&1
            echo "$name $bin $(cat "$scratch/t")" >> "$out"
        done
    done
done
rm -rf "$scratch"
