#!/usr/bin/env python3
"""A jerk-limited motion along a program's stations, found by sequential linear programs:
an estimate, from above, of the least time that `schedule::lower_bound_time_s` bounds from
below (MODEL.md §6.1, "Which side is loose").

Input: the stations CSV of `cargo run --release -p dexcut --example jerk_piece -- JOB.toml
FROM TO OUT.csv` (arc length s, cap, the tangential acceleration and jerk limits of the
interval after each station, stop, planned speed). Needs numpy and scipy (HiGHS):
`pip install scipy`. Not part of the tests.

The motion: b_k = v_k² and the tangential acceleration a_k at each station, a linear in s
between stations (so b_k+1 − b_k = (a_k + a_k+1)·Δs), rest (b = a = 0) at every stop,
b_k ≤ cap_k², |a| within each interval's limit, and the jerk a'(s)·v within the interval's
limit at both of its stations: |a_k+1 − a_k| ≤ J·Δs/v_j, j = k, k+1. 1/v = b^(−1/2) is
convex in b, so its tangent at the last iterate lies below it, and every LP solution keeps
that jerk limit. Each iterate maximises the first-order decrease of the time
Σ 2Δs/(v_k + v_k+1) within a trust region on b; the best time found is printed, with the
same motion's time integrated in closed quadrature away from the stops. What it does not
check: the jerk between stations (a linear in s, v between its two station values), the
speed between stations against the larger cap, and the servo samples' per-axis limits.

usage: jerk_optimum.py STATIONS.csv [ITERATIONS [OUT.csv]]
"""
import sys

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog


def trapezoid_time_s(ds, b):
    v = np.sqrt(np.maximum(b, 0.0))
    return float(np.sum(2.0 * ds / np.maximum(v[:-1] + v[1:], 1e-12)))


def integrated_time_s(ds, b, a, stop):
    """∫ ds / √b with b quadratic in s on each interval (8-point Gauss–Legendre), except on
    the intervals that touch a stop (b = 0 there), which keep the trapezoid time."""
    x, w = np.polynomial.legendre.leggauss(8)
    u = 0.5 * (x + 1.0)
    total = 0.0
    for k in range(len(ds)):
        if stop[k] or stop[k + 1]:
            total += trapezoid_time_s(ds[k : k + 1], b[k : k + 2])
            continue
        xs = u * ds[k]
        bx = b[k] + 2.0 * a[k] * xs + (a[k + 1] - a[k]) * xs**2 / ds[k]
        total += 0.5 * ds[k] * float(np.sum(w / np.sqrt(np.maximum(bx, 1e-18))))
    return total


def main():
    d = np.genfromtxt(sys.argv[1], delimiter=",", names=True)
    iterations = int(sys.argv[2]) if len(sys.argv) > 2 else 25
    s, cap, acc, jerk, plan_v = d["s"], d["cap"], d["accel"], d["jerk"], d["plan_v"]
    stop = d["stop"] > 0
    n = len(s)
    m = n - 1
    ds = np.diff(s)
    idx = np.arange(m)
    # A station's acceleration is within the limits of both intervals beside it.
    a_lim = np.full(n, np.inf)
    a_lim[:-1] = np.minimum(a_lim[:-1], acc[:m])
    a_lim[1:] = np.minimum(a_lim[1:], acc[:m])
    # b = a = 0 and b ≡ 0 are feasible: the plan's speeds only seed the trust region.
    bb = np.minimum(plan_v**2, cap**2) * 0.98
    bb[stop] = 0.0
    best_s, best_x = np.inf, None
    rho = 0.5
    # b_k+1 − b_k − (a_k + a_k+1)Δs = 0
    rr = np.arange(m)
    a_eq = sp.csr_matrix(
        (
            np.concatenate([np.ones(m), -np.ones(m), -ds, -ds]),
            (np.concatenate([rr] * 4), np.concatenate([idx + 1, idx, n + idx, n + idx + 1])),
        ),
        shape=(m, 2 * n),
    )
    a_bounds = [(0.0, 0.0) if stop[k] else (-a_lim[k], a_lim[k]) for k in range(n)]
    for it in range(iterations):
        v = np.sqrt(np.maximum(bb, 1e-12))
        grad = np.zeros(n)
        term = -2.0 * ds / np.maximum(v[:-1] + v[1:], 1e-9) ** 2
        grad[:-1] += term / (2.0 * v[:-1])
        grad[1:] += term / (2.0 * v[1:])
        rows, cols, vals, rhs = [], [], [], []
        r = 0
        for side in (0, 1):
            st = idx + side
            ok = ~stop[st] & (bb[st] > 0.0)
            k, j = idx[ok], st[ok]
            bj = bb[j]
            # J·Δs·(tangent of b^(−1/2) at bj) = J·Δs·(1.5/√bj − b/(2·bj^1.5))
            c0 = jerk[k] * ds[k] * 1.5 / np.sqrt(bj)
            c1 = jerk[k] * ds[k] / (2.0 * bj**1.5)
            for sign in (1.0, -1.0):
                rows_k = r + np.arange(len(k))
                rows += [rows_k] * 3
                cols += [n + k + 1, n + k, j]
                vals += [np.full(len(k), sign), np.full(len(k), -sign), c1]
                rhs.append(c0)
                r += len(k)
        a_ub = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(r, 2 * n)
        )
        hi = np.minimum(cap**2, bb * (1.0 + rho) + 1e-3)
        hi[stop] = 0.0
        bounds = [(0.0, hi[k]) for k in range(n)] + a_bounds
        res = linprog(
            np.concatenate([grad, np.zeros(n)]),
            A_ub=a_ub,
            b_ub=np.concatenate(rhs),
            A_eq=a_eq,
            b_eq=np.zeros(m),
            bounds=bounds,
            method="highs",
        )
        if res.status != 0:
            print(f"iteration {it}: {res.message}", flush=True)
            rho *= 0.5
            continue
        b_new = res.x[:n]
        t = trapezoid_time_s(ds, b_new)
        if t < best_s:
            best_s, best_x = t, res.x.copy()
        elif it > 0:
            rho *= 0.8
        print(f"iteration {it}: trust {rho:.3f}, time {t:.4f} s, best {best_s:.4f} s", flush=True)
        bb = b_new
    b, a = best_x[:n], best_x[n:]
    print(
        f"stations {n}: planned speeds (before the filter) {trapezoid_time_s(ds, np.minimum(plan_v**2, cap**2)):.4f} s; "
        f"jerk-limited motion {best_s:.4f} s (integrated {integrated_time_s(ds, b, a, stop):.4f} s)"
    )
    if len(sys.argv) > 3:
        np.savetxt(
            sys.argv[3],
            np.column_stack([s, cap, np.sqrt(np.maximum(b, 0.0)), a, plan_v, acc]),
            delimiter=",",
            header="s,cap,v,a,plan_v,accel",
            comments="",
        )


if __name__ == "__main__":
    main()
