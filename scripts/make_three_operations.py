#!/usr/bin/env python3
"""Writes examples/three_operations/: three programs that make one part, a
trough z = 13 + 4·((x − 30)/30)² mm across a 60 × 40 × 20 mm box, as a shop
posts them, one file per operation:

  rough.nc   T1, Ø8 flat end: trochoidal (adaptive-style) clearing in levels
             of 1 mm, 0.3 mm left above the trough, lanes along Y;
  semi.nc    T2, Ø6 bull nose r1: a raster along X, 2 mm step-over, the tip
             0.2 mm above the trough;
  finish.nc  T3, Ø6 ball end: a raster along X, 0.5 mm step-over, on the trough.

Each program starts with its tool change (T… M6), retracts to Z25 and ends
with M30. Tool tips, mm, the finishing tools placed on the trough by drop
cutter (each tool's profile lowered until it touches).
"""
import math
import os

OUT = os.path.join(os.path.dirname(__file__), "..", "examples", "three_operations")
X0, X1, Y0, Y1, TOP = 0.0, 60.0, 0.0, 40.0, 20.0
SAFE = 25.0


def trough(x):
    return 13.0 + 4.0 * ((x - 30.0) / 30.0) ** 2


def drop(x, radius, corner):
    """The tool tip's z at x when the tool (radius, corner radius; a ball has
    corner = radius) is lowered onto the trough: max over the footprint of
    the trough minus the tool's bottom at that distance (drop cutter; the
    trough is constant along y, so the lowest point of the tool over a
    distance u along x is its profile at u). Only x inside the box holds
    material."""
    best = -math.inf
    n = 400
    for i in range(-n, n + 1):
        u = radius * i / n
        xs = x + u
        if not (X0 <= xs <= X1):
            continue
        r = abs(u)
        flat = radius - corner
        h = 0.0 if r <= flat else corner - math.sqrt(max(corner ** 2 - (r - flat) ** 2, 0.0))
        best = max(best, trough(xs) - h)
    return best


def f(v):
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def header(name, tool, what, rpm):
    return [
        "%",
        f"({name}: {what})",
        "(made by scripts/make_three_operations.py; mm, tool tip)",
        "G21 G17 G90 G94",
        f"T{tool} M6",
        f"S{rpm} M3",
        f"G0 Z{f(SAFE)}",
    ]


def footer():
    return [f"G0 Z{f(SAFE)}", "M5", "M30", "%"]


def rough():
    r_tool, r_troch, advance, lane, allow, level = 4.0, 2.0, 0.8, 10.0, 0.3, 1.0
    lines = header("rough", 1, "trochoidal clearing, Ø8 flat end", 8000)
    z = TOP - level
    while True:
        # The lanes' centres: evenly spaced, at most `lane` apart, so that the
        # loops' footprints cover the band of x where the flat bottom stays
        # above the trough plus the allowance (no material beyond the box).
        reach = r_tool + r_troch
        h = 30.0 * math.sqrt(max(z - allow - 13.0, 0.0) / 4.0)
        lo = max(30.0 - h, X0 - r_tool) + reach
        hi = min(30.0 + h, X1 + r_tool) - reach
        n = math.ceil((hi - lo) / lane) + 1 if hi >= lo else 0
        xs = [lo + (hi - lo) * i / max(n - 1, 1) for i in range(n)]
        if not xs:
            break
        for xc in xs:
            y = Y0 - r_tool - r_troch - 1.0
            lines.append(f"G0 X{f(xc + r_troch)} Y{f(y)}")
            lines.append(f"G0 Z{f(z + 2)}")
            lines.append(f"G1 Z{f(z)} F300")
            first = True
            while y <= Y1 + r_tool + r_troch:
                for k in range(1, 25):
                    a = 2 * math.pi * k / 24
                    px = xc + r_troch * math.cos(a)
                    py = y + advance * k / 24 + r_troch * math.sin(a)
                    lines.append(f"G1 X{f(px)} Y{f(py)}" + (" F1500" if first else ""))
                    first = False
                y += advance
            lines.append(f"G0 Z{f(SAFE)}")
        z -= level
    return lines + footer()


def raster(name, tool, what, rpm, step, lift, feed, radius, corner):
    lines = header(name, tool, what, rpm)
    y, forward = Y0, True
    lines.append(f"G0 X{f(X0 - 2.5)} Y{f(y)}")
    lines.append(f"G1 Z{f(drop(X0 - 2.5, radius, corner) + lift)} F{feed}")
    while y <= Y1 + 1e-9:
        xs = [X0 - 2.5 + 0.5 * i for i in range(int((X1 - X0 + 5) / 0.5) + 1)]
        if not forward:
            xs.reverse()
        for x in xs:
            lines.append(f"G1 X{f(x)} Z{f(drop(x, radius, corner) + lift)}")
        y += step
        if y <= Y1 + 1e-9:
            lines.append(f"G1 Y{f(y)}")
        forward = not forward
    return lines + footer()


def main():
    os.makedirs(OUT, exist_ok=True)
    programs = {
        "rough.nc": rough(),
        "semi.nc": raster("semi", 2, "raster along X, Ø6 bull nose r1, 0.2 mm left", 9000, 2.0, 0.2, 1500, 3.0, 1.0),
        "finish.nc": raster("finish", 3, "raster along X, Ø6 ball end", 10000, 0.5, 0.0, 1800, 3.0, 3.0),
    }
    for name, lines in programs.items():
        with open(os.path.join(OUT, name), "w") as fh:
            fh.write("\n".join(lines) + "\n")
        print(name, len(lines), "lines")


if __name__ == "__main__":
    main()
