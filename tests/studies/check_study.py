#!/usr/bin/python3
"""Checks a small accuracy study's output (tests/studies/accuracy_small.sh): CASE_spacing.csv has
its 4 rows and the columns every run records, the plot is written, and the case's errors fall
as stated below, at the observed orders measured (the CPU runs are deterministic).
Usage: check_study.py CASE OUTDIR"""
import csv
import os
import sys

import numpy as np


def order_of(h, e):
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def hydrostatic(rows, h, e):
    for k in range(1, len(rows)):
        assert e[k] < e[k - 1], f"the error grew from spacing {h[k-1]} to {h[k]}: {e[k-1]} -> {e[k]}"
    order = order_of(h, e)
    print(f"observed order {order:.2f}")
    # Measured 1.56 over spacings 0.02..0.0075 (errors 2.1%, 1.7%, 0.75%, 0.50% of rho0 g H):
    # between first order (the kernel's truncation near the free surface and the walls) and
    # second (its interior). A coarser 0.03 (5 particles across the tank) is off the asymptote
    # (11.6%) and left out.
    lo, hi = 1.4, 1.75
    assert lo <= order <= hi, f"observed order {order:.2f} outside [{lo}, {hi}]"


def dambreak(rows, h, e):
    for r in rows:
        for key in ("front_rms", "height_rms", "release_delay"):
            assert r.get(key), f"no {key} in {r}"
    order = order_of(h, e)
    print(f"against the experiment: errors {e}, observed order {order:.2f}")
    # Measured 3.61%, 3.21%, 2.60%, 2.59%, order 0.38. Against an experiment the error falls
    # toward a floor, not to zero: the digitised curves' scatter (about 2%) and a gate's release
    # that an instant one cannot match (the H100's full study, 10 to 80 particles across: 3.23%,
    # 2.64%, 2.21%, 2.18%). So: lower at the finest than the coarsest by at least a fifth, never
    # above the coarsest, within the floor's band, and the order stated.
    assert e[-1] < 0.8 * e[0], f"the error fell from {e[0]:.4f} to only {e[-1]:.4f}"
    assert max(e) == e[0], f"a finer run's error above the coarsest's: {e}"
    assert 0.02 <= e[-1] <= 0.03, f"the finest run's error {e[-1]:.4f} outside [2%, 3%]"
    lo, hi = 0.3, 0.46
    assert lo <= order <= hi, f"observed order {order:.2f} outside [{lo}, {hi}]"
    # Against our own finest run (0.01), what theory says must converge: the coarser runs' front
    # and height curves approach it at every refinement (self errors 2.9%, 2.1%, 0.57%), order
    # 2.41 (high: the reference is itself 0.01 from the limit, which flatters the finest pair).
    s = [float(r["self_error"]) for r in rows[:-1]]
    for k in range(1, len(s)):
        assert s[k] < s[k - 1], f"the self error grew: {s}"
    self_order = order_of(h[:-1], s)
    print(f"observed order against the finest run {self_order:.2f}")
    assert 2.0 <= self_order <= 2.8, f"observed order {self_order:.2f} outside [2.0, 2.8]"


def main():
    case, out = sys.argv[1:3]
    with open(os.path.join(out, f"{case}_spacing.csv")) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4, f"{len(rows)} rows, not 4"
    for r in rows:
        for key in ("particles", "steps", "wall_s", "memory_mb", "device", "commit"):
            assert r.get(key), f"no {key} in {r}"
    assert os.path.getsize(os.path.join(out, f"{case}_spacing.png")) > 10000, "no plot"
    h = [float(r["value"]) for r in rows]
    e = [float(r["error"]) for r in rows]
    {"hydrostatic": hydrostatic, "dambreak": dambreak}[case](rows, h, e)


if __name__ == "__main__":
    main()
