#!/usr/bin/env bash
# Whole runs of the release binary: wall time, CPU time and peak memory
# (/usr/bin/time -v) of
#   * the raster finish (200 rows × 202 points, 40 399 moves, 100 × 100 mm,
#     Ø10 ball) as a CSV point list and as G-code, simulate at grid 0.25 / 0.1 / 0.05;
#   * the 1 M-block program (1000 × 1000 points, 999 999 G1 blocks) at grid 0.1,
#     simulate and optimize;
#   * the free path (240 G1 moves over an 80 × 60 mm block, Ø6 ball) at grid
#     0.05, simulate with the closed loop (the default) and without;
#   * two long real ball-end programs (crates/dexcut/benches/programs/real:
#     A, CAMotics' cameo, 35 288 lines, Ø2 ball, 724 227 servo steps; B,
#     CAMotics' bear, 15 163 lines, 1/8" ball), simulate and optimize at grid
#     0.1 with their jobs; the programs are decompressed (xz) into WORKDIR.
# Programs and jobs are written by `examples/bench_programs.rs` (the same
# generator as the criterion benches). Prints one Markdown table row per run,
# with the load average before it, as BENCHMARKS.md records them.
#
# Usage: scripts/bench_runs.sh [WORKDIR] [FILTER]   (FILTER: a substring of the run names:
#        raster, free_path, 1m, real, real_A, ...)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-$root/target/bench_runs}
filter=${2:-}
cd "$root"
cargo build --release -q -p dexcut-cli
cargo run --release -q -p dexcut --example bench_programs -- "$work" > /dev/null
bin=$root/target/release/dexcut
real=$root/crates/dexcut/benches/programs/real
mkdir -p "$work"
for p in "$real"/*.nc.xz; do
    xz -dc "$p" > "$work/$(basename "$p" .xz)"
done
cp "$real"/*.toml "$work"/
cd "$work"

run() {
    local name=$1
    shift
    [[ -n $filter && $name != *"$filter"* ]] && return 0
    local load
    load=$(cut -d' ' -f1 /proc/loadavg)
    if ! /usr/bin/time -v "$bin" "$@" > "$name.out" 2> "$name.time"; then
        echo "| $name | failed: $(grep -m1 error "$name.time") |"
        return 0
    fi
    local wall user sys rss
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$name.time")
    user=$(awk -F': ' '/User time/ {print $2}' "$name.time")
    sys=$(awk -F': ' '/System time/ {print $2}' "$name.time")
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$name.time")
    printf '| %s | `dexcut %s` | %.2f s | %.2f s | %s MiB | %s |\n' \
        "$name" "$*" "$wall" "$(echo "$user + $sys" | bc)" "$rss" "$load"
}

echo "| run | command | wall | CPU (user + sys) | peak RSS | load before |"
echo "| --- | --- | --- | --- | --- | --- |"
for g in 0.25 0.1 0.05; do
    run "raster_csv_$g" simulate raster_csv.toml --grid "$g" --out "out_raster_csv_$g" --force
done
for g in 0.25 0.1 0.05; do
    run "raster_gcode_$g" simulate raster_ngc.toml --grid "$g" --out "out_raster_ngc_$g" --force
done
run "free_path_0.05" simulate free_path_ngc.toml --out out_free_path --force
sed 's/^\[cutting\]/[cutting]\nclosed_loop = false/' free_path_ngc.toml > free_path_open.toml
run "free_path_0.05_open_loop" simulate free_path_open.toml --out out_free_path_open --force
run "1m_simulate_0.1" simulate finish_1m_ngc.toml --out out_1m_simulate --force
run "1m_optimize_0.1" optimize finish_1m_ngc.toml --out out_1m_optimize --force
run "real_A_simulate" simulate camotics_cameo.toml --out out_real_A_simulate --force
run "real_A_optimize" optimize camotics_cameo.toml --out out_real_A_optimize --force
run "real_B_simulate" simulate camotics_bear.toml --out out_real_B_simulate --force
run "real_B_optimize" optimize camotics_bear.toml --out out_real_B_optimize --force
