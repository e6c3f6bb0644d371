#!/usr/bin/python3
"""Write the reference programs: unit cases, and real programs from
crates/nc/tests/data/real trimmed to their first N lines with M2 appended.
Run from the repository root; writes
crates/schedule/tests/data/linuxcnc_reference/programs/*.ngc."""
import os

REAL = "crates/nc/tests/data/real"
OUT = "crates/schedule/tests/data/linuxcnc_reference/programs"

# (name, source file, first lines kept)
TRIMMED = [
    ("adaptive_corner", "freecad_corner_20_20_adaptive.nc", 300),
    ("adaptive_hole", "freecad_hole_7mm_adaptive.nc", 220),
    ("finish_flower_mold", "camotics_flower_mold_trimmed.nc", 45),
    ("finish_tiger", "camotics_tiger_trimmed.nc", 14),
    ("finish_bear", "camotics_bear_trimmed.nc", 300),
    ("finish_wave", "camotics_wave.gcode", 120),
    ("engrave_locket", "camotics_locket_engrave.ngc", 400),
    ("engrave_tiny_cat_g61", "camotics_tiny_cat_outline.ngc", 500),
    ("pocket_medial", "blendercam_MedialPocket.gcode", 400),
    ("pcb_carbide_copper", "carbidecopper_pcb.nc", 400),
    ("pcb_flatcam_isolation", "flatcam_kroneum_isolation_trimmed.nc", 250),
]

UNIT = {
    "corner_g61": "G21 G90 G17 G61\nG0 X0 Y0 Z1\nG1 Z0 F600\nG1 X20 F1800\nG1 Y20\nM2\n",
    "corner_g64": "G21 G90 G17 G64\nG0 X0 Y0 Z1\nG1 Z0 F600\nG1 X20 F1800\nG1 Y20\nM2\n",
    "corner_g64_p005": "G21 G90 G17 G64 P0.05\nG0 X0 Y0 Z1\nG1 Z0 F600\nG1 X20 F1800\nG1 Y20\nM2\n",
    "corner_g64_p005_q002_obtuse": "G21 G90 G17 G64 P0.05 Q0.02\nG1 X20 Y0 F2400\nG1 X35 Y8\nG1 X35 Y30\nM2\n",
    "zigzag_short_g64_p002": "G21 G90 G17 G64 P0.02\nG1 F3000\n"
    + "".join(f"G1 X{0.5 * (i + 1):.1f} Y{0.3 if i % 2 == 0 else 0.0:.1f}\n" for i in range(120))
    + "M2\n",
    "zigzag_short_g64": "G21 G90 G17 G64\nG1 F3000\n"
    + "".join(f"G1 X{0.5 * (i + 1):.1f} Y{0.3 if i % 2 == 0 else 0.0:.1f}\n" for i in range(120))
    + "M2\n",
    "collinear_short_g64_p01_q005": "G21 G90 G17 G64 P0.1 Q0.05\nG1 F2400\n"
    + "".join(f"G1 X{0.2 * (i + 1):.3f} Y{0.001 * ((i * 7) % 3):.3f}\n" for i in range(200))
    + "G1 Y10\nM2\n",
    "line_arc_corners_g64_p002": "G21 G90 G17 G64 P0.02\nG1 X10 Y0 F1500\nG2 X20 Y0 I5 J0\n"
    + "G1 X30 Y5\nG3 X40 Y5 I5 J0\nG1 X40 Y15\nM2\n",
    "arc_arc_corner_g64_p002": "G21 G90 G17 G64 P0.02\nF1500\nG2 X10 Y0 I5 J0\n"
    + "G2 X15 Y-5 I0 J-5\nG3 X25 Y-5 I5 J0\nG1 X25 Y-15\nM2\n",
    "arcs_g64_p001": "G21 G90 G17 G64 P0.01\nG1 X10 Y0 F1500\nG3 X20 Y10 R10\nG2 X30 Y20 R10\nG1 X30 Y30\nG2 X40 Y40 I10 J0\nM2\n",
}


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, text in UNIT.items():
        with open(f"{OUT}/{name}.ngc", "w") as f:
            f.write(f"(dexcut reference unit case {name})\n{text}")
    for name, src, n in TRIMMED:
        raw = open(f"{REAL}/{src}", "rb").read().decode("utf-8", "replace")
        lines = raw.replace("\ufeff", "").replace("\r", "").split("\n")[:n]
        lines = [l for l in lines if l.strip() not in ("%",)]
        with open(f"{OUT}/{name}.ngc", "w") as f:
            f.write(f"(dexcut reference: the first {n} lines of {REAL}/{src}, then M2)\n")
            f.write("\n".join(lines) + "\nM2\n")


main()
