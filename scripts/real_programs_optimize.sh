#!/usr/bin/env bash
# Runs `dexcut optimize` on every real program in crates/nc/tests/data/real/
# and prints, per program, the closing-note table of issue 12: cycle time
# before and after, the written program (optimized.nc) simulated again as a
# program of its own, the peak MRR per period against mrr_max, the top cutting
# feed against the programmed one and the chip-load feed. servo.csv is also
# simulated as a program (results.json: servo_s, servo_removed, servo_peak,
# servo_force against after_s, removed_after, peak_after, force_after).
#
# The job per program: a box stock around the program's feed moves (tool
# radius + 2 mm each side, from 1 mm under the deepest feed move to z = 0, or
# 0.5 mm above an engraving that runs at z ≥ 0), the tool from the table below
# (from the program's comments or its makers' examples; flute length the
# stock's depth the program cuts + 0.2 mm, at least 3 diameters; cutters under
# 1/8" on a 1/8" shank), aluminium 6061 (chip-load default of MODEL.md §2.1),
# feed_max 5000 mm/min, rapid 10000 mm/min, and mrr_max = half the program's
# own peak MRR over ≥ 48 ms, so the limit binds. EXTRA_LIMITS is added to
# [limits] (e.g. EXTRA_LIMITS="stress = false" to run without the stress limit).
# Programs for a machine whose Z points down (Z_DOWN) are read with
# [machine] z_axis = "down".
#
# Usage: scripts/real_programs_optimize.sh [OUT_DIR] [PROGRAM_NAME_PREFIX...]
# Needs the release binary (cargo build --release) and python3.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-/tmp/dexcut_real_programs}"
shift || true
bin="$root/target/release/dexcut"
[ -x "$bin" ] || { echo "build first: cargo build --release" >&2; exit 1; }
mkdir -p "$out"
exec python3 - "$root" "$out" "$bin" "$@" <<'PY'
import csv, json, math, os, subprocess, sys, time

root, out, binary = sys.argv[1:4]
only = sys.argv[4:]
data = os.path.join(root, "crates/nc/tests/data/real")
# name prefix: (kind, diameter mm, grid mm)
TOOLS = {
    "camotics_bear": ("ball", 3.175, 0.1),
    "camotics_botomata": ("flat", 3.175, 0.1),
    "camotics_buildbotics": ("flat", 3.175, 0.2),
    "camotics_cameo": ("ball", 3.175, 0.1),
    "camotics_cds": ("flat", 3.175, 0.1),
    "camotics_flower_mold": ("ball", 3.175, 0.1),
    "camotics_genes_encoder": ("flat", 1.5, 0.1),
    "camotics_la_peinture": ("flat", 1.0, 0.1),
    "camotics_locket_engrave": ("ball", 1.0, 0.1),
    "camotics_scorpion": ("flat", 3.175, 0.2),
    "camotics_tiger": ("ball", 3.175, 0.1),
    "camotics_tiny_cat": ("flat", 1.5875, 0.1),
    "camotics_wave": ("ball", 3.175, 0.2),
    "fusion_led_floor_block": ("flat", 1.4, 0.1),
    "fusion_led_floor_1022": ("flat", 1.4, 0.1),
    "fusion_led_floor_1072": ("flat", 40.0, 0.5),
    "fusion_led_floor_bore": ("flat", 2.7, 0.1),
    "fusion_led_floor_light": ("flat", 2.7, 0.1),
    "fusion_led_floor_surface": ("flat", 40.0, 0.5),
    "cambam_piezagopro": ("flat", 3.0, 0.1),
    "cambam_communicator": ("flat", 3.175, 0.1),
    "cambam_electric_turtle": ("flat", 3.175, 0.1),
    "cambam_shapeoko_engrave": ("flat", 1.0, 0.1),
    "pycam_shapeoko": ("flat", 1.0, 0.1),
    "sketchucam_arc_rword": ("flat", 3.175, 0.1),
    "ugs_designer": ("flat", 3.0, 0.1),
    "estlcam_backplate": ("flat", 3.175, 0.1),
    "estlcam_enclosure": ("flat", 2.0, 0.1),
    "estlcam_spool_fixture": ("flat", 2.0, 0.1),
    "freecad_corner_20_20": ("flat", 3.0, 0.1),
    "freecad_hole_7mm": ("flat", 6.0, 0.1),
    "freecad_plate8": ("flat", 3.0, 0.1),
    "fusion_tap_heatsink": ("flat", 3.175, 0.1),
    "fusion_haas_rebels5": ("flat", 3.175, 0.1),
    "haas_cline_maze": ("flat", 3.175, 0.1),  # no diameter in the program: assumed
    "haas_smiley": ("flat", 3.175, 0.1),  # no diameter in the program: assumed
    "haas_writing_a_program": ("flat", 3.175, 0.1),  # no diameter in the program: assumed
    "linuxcnc_3dtest": ("flat", 3.175, 0.2),  # no diameter in the program: assumed
    "linuxcnc_arcspiral": ("flat", 3.175, 0.2),  # no diameter in the program: assumed
    "linuxcnc_flowsnake": ("flat", 3.175, 0.2),  # no diameter in the program: assumed
    "linuxcnc_hk_ba20": ("flat", 6.0, 0.2),  # no diameter in the program: assumed
    "linuxcnc_hole_circle": ("flat", 6.35, 0.2),  # no diameter in the program: assumed
    "linuxcnc_polar": ("flat", 6.35, 0.2),  # no diameter in the program: assumed
    "linuxcnc_interp_g17": ("flat", 6.35, 0.2),  # a 1/4 in tap for its G84 holes: assumed
    "linuxcnc_skeleton": ("flat", 3.175, 0.2),  # no diameter in the program: assumed
    "linuxcnc_spiral": ("flat", 3.175, 0.2),  # no diameter in the program: assumed
    "linuxcnc_tort": ("ball", 3.175, 0.2),  # no diameter in the program: assumed
    "uccnc_sensor_v4": ("flat", 0.397, 0.05),
    "fusion_haas_sprayer_face": ("flat", 152.4, 1.0),
    "fusion_sprayer_output": ("flat", 152.4, 1.0),
    "fusion_sprayer_working": ("flat", 50.8, 0.5),
    "pcb2gcode_outline": ("flat", 1.5, 0.05),
    "pcb2gcode_drill": ("flat", 0.4, 0.05),
    "pcb2gcode_milldrill": ("flat", 1.0, 0.05),
    "pcb2gcode_back": ("flat", 0.2, 0.05),
    "bcnc_sample": ("flat", 0.6, 0.05),  # no diameter in the program: assumed
    "escriba_grbl": ("flat", 0.5, 0.05),  # no diameter in the program: assumed
    "jscut_": ("flat", 3.175, 0.1),  # no diameter in the program: assumed
    "openbuilds_cam": ("flat", 1.0, 0.05),
    "estlcam11": ("flat", 3.0, 0.1),
    "drl2gcode_kicad_T02": ("flat", 0.4, 0.05),
    "dxf2gcode_erin7": ("flat", 3.0, 0.1),  # no diameter in the program: assumed
    "fusion_proxxon_key": ("flat", 1.587, 0.05),
    "gcodekit4_designer": ("flat", 3.175, 0.2),
    "mastercam_helix_bores": ("flat", 3.0, 0.1),
    "ncefi_pockets": ("flat", 6.0, 0.2),  # no diameter in the program: assumed
    "pycut_kasten": ("flat", 3.0, 0.1),
    "pygen_norn93": ("flat", 3.0, 0.1),
    "flatcam_kroneum_isolation": ("flat", 0.24, 0.05),
    "flatcam_kroneum_holes": ("flat", 0.8, 0.05),  # no diameter in the program: assumed
    "flatcam_kroneum_cutout": ("flat", 1.5, 0.1),
    "fusion_linuxcnc_kroneum_base": ("flat", 1.5, 0.1),
    "fusion_linuxcnc_kroneum_usb": ("flat", 0.9, 0.05),  # the Ø0.9 drill as a flat end
    "pcbgcode_cr78_drill": ("flat", 0.8, 0.05),  # T01, the first of seven drills
    "pcbgcode_cr78_bot_mill": ("flat", 1.5875, 0.1),  # no diameter in the program: assumed
    "pcbgcode_cr78_etch": ("flat", 0.2, 0.05),  # no diameter in the program: assumed
    "carbidecopper_pcb": ("flat", 0.2, 0.05),  # T501 (engraving), no diameter: assumed
    "grblplotter_": ("flat", 1.0, 0.1),  # no diameter in the program: assumed
    "freecad_path_raw": ("flat", 5.0, 0.2),  # FreeCAD's "Default Tool": assumed 5 mm
}
DEFAULT_TOOL = ("flat", 3.0, 0.1)
# Shank of the tools smaller than it, mm (1/8").
SHANK_MM = 3.175
# Programs written for a machine whose Z points down ([machine] z_axis =
# "down"): Estlcam 10's custom post of Cluck2Sesame (its README row), whose
# safe height is Z-25 / Z-20 and whose cuts go to +Z below "Z on top of the
# sheet" (their header comments).
Z_DOWN = ("estlcam_backplate", "estlcam_enclosure", "estlcam_spool_fixture")


def tool_of(name):
    for prefix, t in TOOLS.items():
        if name.startswith(prefix):
            return t
    return DEFAULT_TOOL


def run(args, cwd):
    return subprocess.run([binary] + args, cwd=cwd, capture_output=True, text=True)


def last_line(text):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return lines[-1][:160] if lines else ""


rows = []
for f in sorted(os.listdir(data)):
    if f.endswith(".md"):
        continue
    name = f.rsplit(".", 1)[0]
    if only and not any(name.startswith(o) for o in only):
        continue
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    prog = os.path.join(data, f)
    kind, dia, grid = tool_of(name)
    z_axis = 'z_axis = "down"\n' if name.startswith(Z_DOWN) else ""
    t0 = time.time()
    # Probe: where the feed moves are (a far-away one-cell stock, nothing removed).
    probe = f'[stock]\nkind = "box"\nmin = [-5000, -5000, -9000]\nmax = [5000, 5000, -8990]\ngrid = 50\n[tool]\nkind = "flat"\ndiameter = 3\n[program]\npath = "{prog}"\n[machine]\n{z_axis}'
    open(os.path.join(d, "probe.toml"), "w").write(probe)
    # steps.csv whatever the length (read below; --steps-format auto writes .npy above 200 000 steps).
    p = run(["simulate", "probe.toml", "--out", "probe", "--force", "--steps-format", "csv"], d)
    if p.returncode:
        rows.append(dict(name=name, status="not read: " + last_line(p.stderr)))
        continue
    pts = [
        (float(r["x"]), float(r["y"]), float(r["z"]))
        for r in csv.DictReader(open(os.path.join(d, "probe/steps.csv")))
        if r["rapid"] == "0"
    ]
    if not pts:
        rows.append(dict(name=name, status="no feed moves"))
        continue
    lo = [min(p[i] for p in pts) for i in range(3)]
    hi = [max(p[i] for p in pts) for i in range(3)]
    margin = dia / 2 + 2
    top = 0.0 if lo[2] < 0 else lo[2] + 0.5
    bottom = lo[2] - 1.0
    # Flutes as long as the program cuts deep (the stock from its top to the
    # deepest feed move, and 0.2 mm more), at least 3 diameters: a tool made
    # for the cut, not a 2 mm longer sliver (a Ø0.2 tool had 15 diameters of
    # flutes). Cutters under 1/8" have a 1/8" (3.175 mm) shank, as PCB and
    # hobby micro tools do, rather than a shank as thin as the cutter.
    flute = max(3 * dia, top - lo[2] + 0.2)
    shank = f"shank_diameter = {SHANK_MM}\n" if dia < SHANK_MM else ""

    def job(path, limits):
        return (
            f'[stock]\nkind = "box"\nmin = [{lo[0]-margin:.3f}, {lo[1]-margin:.3f}, {bottom:.3f}]\n'
            f'max = [{hi[0]+margin:.3f}, {hi[1]+margin:.3f}, {top:.3f}]\ngrid = {grid}\n'
            f'[tool]\nkind = "{kind}"\ndiameter = {dia}\nflute_length = {flute:.3f}\nstickout = {flute + 10:.3f}\n'
            f"{shank}"
            f'[program]\npath = "{path}"\n[cutting]\nmaterial = "al6061"\n'
            f"[machine]\nfeed_max = 5000\nrapid = 10000\n{z_axis}[limits]\n{limits}"
        )

    open(os.path.join(d, "sim.toml"), "w").write(job(prog, ""))
    s = run(["simulate", "sim.toml", "--out", "sim", "--force"], d)
    if s.returncode:
        rows.append(dict(name=name, status="simulate failed: " + last_line(s.stderr)))
        continue
    S = json.load(open(os.path.join(d, "sim/summary.json")))
    if S["removed_volume_mm3"] <= 1e-6:
        rows.append(dict(name=name, status="removes nothing with this stock"))
        continue
    mrr = 0.5 * S["peak_mrr_windowed_mm3_s"]
    limits = f"mrr_max = {mrr:.6g}\n{os.environ.get('EXTRA_LIMITS', '')}\n"
    open(os.path.join(d, "job.toml"), "w").write(job(prog, limits))
    o = run(["optimize", "job.toml", "--out", "opt", "--force", "--steps-format", "csv"], d)
    if o.returncode:
        rows.append(dict(name=name, status="optimize failed: " + last_line(o.stderr)))
        continue
    O = json.load(open(os.path.join(d, "opt/summary.json")))
    written = os.path.join(d, "opt/optimized.nc")
    open(os.path.join(d, "refed.toml"), "w").write(job(written, limits))
    r = run(["simulate", "refed.toml", "--out", "refed", "--force"], d)
    R = json.load(open(os.path.join(d, "refed/summary.json"))) if r.returncode == 0 else {}
    # servo.csv read back as a program (a point list timed by t_s) and simulated.
    open(os.path.join(d, "servo.toml"), "w").write(job(os.path.join(d, "opt/servo.csv"), limits))
    v = run(["simulate", "servo.toml", "--out", "servo", "--force"], d)
    V = json.load(open(os.path.join(d, "servo/summary.json"))) if v.returncode == 0 else {}
    programmed = max((
        float(x["feed_mm_min"])
        for x in csv.DictReader(open(os.path.join(d, "opt/steps_before.csv")))
        if x["rapid"] == "0" and float(x["volume_mm3"]) > 1e-6
    ), default=float("nan"))
    after = O["after"]
    rows.append(
        dict(
            name=name,
            status="ok",
            tool=f"{kind} {dia}",
            grid=grid,
            before_s=O["before"]["cycle_time_s"],
            after_s=after["cycle_time_s"],
            resim_s=R.get("cycle_time_s"),
            plan_s=O["plan_time_s"],
            rounds=O["rounds"],
            mrr_max=mrr,
            peak_before=O["before"]["peak_mrr_mm3_s"],
            peak_after=after["peak_mrr_mm3_s"],
            peak_resim=R.get("peak_mrr_mm3_s"),
            removed_after=after["removed_volume_mm3"],
            servo_s=V.get("cycle_time_s"),
            servo_removed=V.get("removed_volume_mm3"),
            servo_peak=V.get("peak_mrr_mm3_s"),
            servo_force=V.get("peak_force_n"),
            force_after=after["peak_force_n"],
            feed_programmed=programmed,
            feed_after=after["peak_cutting_feed_mm_min"],
            chip_feed=O["limits"]["chip_load_feed_mm_min"],
            kept=O["kept_original"],
            warnings=sorted({w["kind"] for w in after["warnings"]}),
            stress_before=O["before"]["peak_stress_mpa"],
            stress_after=after["peak_stress_mpa"],
            breaks_before=O["before"]["tool_breaks_steps"],
            breaks_after=after["tool_breaks_steps"],
            secs=time.time() - t0,
        )
    )
    print(name, json.dumps(rows[-1]), file=sys.stderr, flush=True)

json.dump(rows, open(os.path.join(out, "results.json"), "w"), indent=1)
print("| program | tool, grid | cycle before → after (s) | optimized.nc re-simulated (s) | vs plan | peak MRR per period before → after / mrr_max (mm³/s) | after / limit | top cutting feed programmed → after (chip-load feed) mm/min | rounds | peak stress before → after (MPa) | steps that break before → after | warnings after |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for x in rows:
    if x["status"] != "ok":
        print(f"| {x['name']} | {x['status']} | | | | | | | | | | |")
        continue
    resim = f"{x['resim_s']:.1f}" if x["resim_s"] is not None else "failed"
    print(
        f"| {x['name']} | {x['tool']}, {x['grid']} | {x['before_s']:.1f} → {x['after_s']:.1f} | {resim} | "
        f"{100 * (x['after_s'] / x['plan_s'] - 1):+.2f} % | {x['peak_before']:.2f} → {x['peak_after']:.2f} / {x['mrr_max']:.2f} | "
        f"{100 * (x['peak_after'] / x['mrr_max'] - 1):+.1f} % | {x['feed_programmed']:.0f} → {x['feed_after']:.0f} ({x['chip_feed']:.0f}) | "
        f"{x['rounds']}{' kept' if x['kept'] else ''} | {x['stress_before']:.0f} → {x['stress_after']:.0f} | "
        f"{x['breaks_before']} → {x['breaks_after']} | {', '.join(x['warnings'])} |"
    )
PY
