#!/usr/bin/env python3
"""Generate the boss_contour reference example (after S4's experiment, seed 004).

The tool path A-F: a line A->B (air), an arc of centre-path radius 20.1705 mm
around the origin through C (-45 deg), D (0 deg) and E (+45 deg) to F', and a
line F'->F (air). R5 ball-end mill, tip at z = 0.

The stock is a boss extruded from z = 0 to z = 8 mm: a circle of radius
20.1705 - 5 = 15.1705 mm (the ball's equator just touches it: no cut) except
between C and E, where the outline is an ellipse with 0.2 mm more material at C
and E (the steps of S4) and 0.05 mm at D. So removal jumps at C and E and is
light around D, as in S4's figure 9.

Writes examples/boss_contour/{boss_contour_stock.stl, boss_contour.nc}.
"""
import math
import os

RP = 20.1705          # centre-path arc radius, mm
R_TOOL = 5.0
RHO0 = RP - R_TOOL    # finished circle radius, mm
STEP = 0.2            # extra material at C and E, mm
AT_D = 0.05           # extra material at D, mm
H = 8.0               # stock height, mm
SECTOR = math.radians(45.0)

a = RHO0 + AT_D                    # ellipse semi-axis along x (at D)
rho_c = RHO0 + STEP                # ellipse radius at +-45 deg
b = math.sqrt(rho_c**2 * a**2 / (2 * a**2 - rho_c**2))


def radius(theta):
    """Stock outline radius at polar angle theta inside the C-E sector."""
    return a * b / math.sqrt((b * math.cos(theta))**2 + (a * math.sin(theta))**2)


def outline():
    pts = []
    n = 720
    for i in range(n):
        th = -math.pi + 2 * math.pi * i / n
        if abs(th) < SECTOR:
            r = radius(th)
        else:
            r = RHO0
        pts.append((th, r))
    # Exact steps at C and E: both radii at the same angle.
    pts += [(-SECTOR, RHO0), (-SECTOR, rho_c), (SECTOR, rho_c), (SECTOR, RHO0)]
    pts.sort(key=lambda p: (p[0], p[1] if p[0] < 0 else -p[1]))
    return [(r * math.cos(th), r * math.sin(th)) for th, r in pts]


def write_stl(path, pts):
    def facet(f, v0, v1, v2):
        ux, uy, uz = (v1[i] - v0[i] for i in range(3))
        wx, wy, wz = (v2[i] - v0[i] for i in range(3))
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        ln = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
        f.write(f"facet normal {nx/ln:.6e} {ny/ln:.6e} {nz/ln:.6e}\n outer loop\n")
        for v in (v0, v1, v2):
            f.write(f"  vertex {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}\n")
        f.write(" endloop\nendfacet\n")

    n = len(pts)
    with open(path, "w") as f:
        f.write("solid boss_contour_stock\n")
        for i in range(n):
            p, q = pts[i], pts[(i + 1) % n]
            # top (counter-clockwise seen from +z), bottom (reversed), side quad
            facet(f, (0.0, 0.0, H), (p[0], p[1], H), (q[0], q[1], H))
            facet(f, (0.0, 0.0, 0.0), (q[0], q[1], 0.0), (p[0], p[1], 0.0))
            facet(f, (p[0], p[1], 0.0), (q[0], q[1], 0.0), (q[0], q[1], H))
            facet(f, (p[0], p[1], 0.0), (q[0], q[1], H), (p[0], p[1], H))
        f.write("endsolid boss_contour_stock\n")


def write_program(path):
    c = RP * math.cos(SECTOR)
    text = f"""%
(boss_contour: after S4's experiment. R5 ball-end mill, tip z = 0)
(path A-F: line A-B in air, arc R{RP} through C, D, E, line F'-F in air)
(0.2 mm stock steps at C and E; light cut around D)
O0001
G21 G17 G90 G54 G94
T1 M6
S6000 M3
G0 X-30. Y-{RP} Z20.
G0 Z5.
G1 Z0. F1500
(A -> B)
G1 X0. Y-{RP}
(B -> C)
G3 X{c:.4f} Y-{c:.4f} I0. J{RP}
(C -> D)
G3 X{RP} Y0. I-{c:.4f} J{c:.4f}
(D -> E)
G3 X{c:.4f} Y{c:.4f} I-{RP} J0.
(E -> F')
G3 X0. Y{RP} I-{c:.4f} J-{c:.4f}
(F' -> F)
G1 X-30.
G0 Z20.
M5
M30
%
"""
    with open(path, "w") as f:
        f.write(text)


if __name__ == "__main__":
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "boss_contour")
    os.makedirs(here, exist_ok=True)
    write_stl(os.path.join(here, "boss_contour_stock.stl"), outline())
    write_program(os.path.join(here, "boss_contour.nc"))
    print(f"ellipse semi-axes a = {a:.4f} mm, b = {b:.4f} mm")
