#!/usr/bin/python3
"""Pack one raw halsampler recording (run.sh's OUT.txt) for the test data.

Keeps the samples from the one before the first that moves to the last that
moves (the program's motion; sample k of the kept ones is at t = k·T). Writes
gzip text: a header, then one line per sample:
`dx dy dz vel line`, where dx dy dz are the second differences of the
position in nm (the first two lines: the position and the first difference),
vel is motion.current-vel in µm/s (integer), line the program line.
"""
import gzip
import sys


def main(raw_path, out_path, name, period_ns):
    rows = []
    for text in open(raw_path):
        f = text.split()
        if len(f) < 5:
            continue
        rows.append((float(f[0]), float(f[1]), float(f[2]), float(f[3]), int(f[4])))
    nm = [tuple(round(r[i] * 1000.0) for i in range(3)) for r in rows]
    moving = [k for k in range(1, len(nm)) if nm[k] != nm[k - 1]]
    if not moving:
        raise SystemExit(f"{raw_path}: no motion recorded")
    first, last = moving[0] - 1, moving[-1]
    nm, rows = nm[first : last + 1], rows[first : last + 1]
    out = [
        "# dexcut LinuxCNC reference recording (scripts/linuxcnc_reference/pack.py)",
        f"name {name}",
        f"period_ns {period_ns}",
        f"samples {len(nm)}",
    ]
    prev, prev_d = (0, 0, 0), (0, 0, 0)
    for k, (p, r) in enumerate(zip(nm, rows)):
        d = tuple(p[i] - prev[i] for i in range(3))
        dd = d if k < 2 else tuple(d[i] - prev_d[i] for i in range(3))
        if k == 1:
            dd = d
        out.append(f"{dd[0]} {dd[1]} {dd[2]} {round(r[3] * 1000.0)} {r[4]}")
        prev, prev_d = p, d
    with gzip.open(out_path, "wt", compresslevel=9) as g:
        g.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]))
