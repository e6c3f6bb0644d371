#!/usr/bin/env bash
# Runs one dexcut binary over a fixed set of jobs, each into its own folder, so
# that two builds can be compared file by file (scripts/cmp_outputs.py): a
# change meant to keep outputs must leave every file cmp-equal (summary.json
# and manifest.json but their timings, run id and input paths).
#
# The set: the default example (optimize) and its job simulated, 3D_Chips
# (optimize, and simulate with a jerk limit of 20 000 mm/s³), twelve real
# programs from crates/nc/tests/data/real (a job fitted to each), and with
# `full` the 1 M-block program (simulate and optimize, peak RSS in times.txt).
#
# Usage: scripts/outputs_set.sh BIN OUT [quick|full]
#   e.g. scripts/outputs_set.sh /tmp/old/dexcut /tmp/out_old full
#        scripts/outputs_set.sh target/release/dexcut /tmp/out_new full
#        scripts/cmp_outputs.py /tmp/out_old /tmp/out_new
set -u
bin=$(realpath "$1"); out=$(realpath -m "$2"); mode=${3:-quick}
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"; cd "$out"
export CI=1
r() {
    local name=$1; shift
    local t0; t0=$(date +%s.%N)
    "$bin" "$@" --out "$out/$name" > "$out/$name.log" 2>&1
    local rc=$?
    echo "$name rc=$rc $(echo "$(date +%s.%N) - $t0" | bc) s" >> "$out/times.txt"
}
# 3D_Chips with a jerk limit (the planner's sections by linear programs).
sed "s#^path = \"../../toolpaths/#path = \"$root/toolpaths/#; s#^accel = \[1000, 1000, 1000\]#&\njerk = [20000, 20000, 20000]#" \
    "$root/examples/3d_chips/job.toml" > "$out/chips_jerk.toml"
r default optimize
r boss_sim simulate "$root/examples/boss_contour/job.toml"
r chips optimize "$root/examples/3d_chips/job.toml"
r chips_jerk simulate "$out/chips_jerk.toml"
R=$root/crates/nc/tests/data/real
r real_bear optimize "$R/camotics_bear_trimmed.nc" --tool ball:3.175
r real_scorpion simulate "$R/camotics_scorpion.nc" --tool flat:3.175 --grid 0.2
r real_freecad_adapt optimize "$R/freecad_corner_20_20_adaptive.nc" --tool flat:6
r real_fusion_surface optimize "$R/fusion_led_floor_surface.nc"
r real_fusion_face simulate "$R/fusion_haas_sprayer_face_inch.nc"
r real_estlcam optimize "$R/estlcam_backplate.nc" --tool flat:3
r real_linuxcnc_3d simulate "$R/linuxcnc_3dtest.ngc" --tool ball:6
r real_blender optimize "$R/blendercam_MedialPocket.gcode" --tool flat:3
r real_cambam optimize "$R/cambam_electric_turtle.nc" --tool flat:3
r real_haas_smiley optimize "$R/haas_smiley.nc" --tool flat:6
r real_grblplotter simulate "$R/grblplotter_dxf_passes.nc" --tool flat:3
if [ "$mode" = full ]; then
    b=$out/bench_programs
    (cd "$root" && cargo run --release -q -p dexcut --example bench_programs -- "$b" > /dev/null)
    r m1_sim simulate "$b/finish_1m_ngc.toml"
    /usr/bin/time -v "$bin" optimize "$b/finish_1m_ngc.toml" --out "$out/m1_opt" > "$out/m1_opt.log" 2> "$out/m1_opt.time"
    echo "m1_opt rc=$? $(grep -E 'Maximum resident|Elapsed' "$out/m1_opt.time" | tr '\n' ' ')" >> "$out/times.txt"
fi
