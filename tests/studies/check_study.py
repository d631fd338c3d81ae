#!/usr/bin/python3
"""Checks a small accuracy study's output (tests/studies/accuracy_small.sh): CASE_AXIS.csv (the
case's resolution axis) has its rows and the columns every run records, the plot is written, and
the case's errors fall as stated below, at the observed orders measured (the CPU runs are
deterministic).
Usage: check_study.py CASE OUTDIR"""
import csv
import os
import sys

import numpy as np


def order_of(h, e):
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def hydrostatic(rows, h, e):
    # A settled tank with the cubic spline at its default support of 2 spacings does not pair:
    # measured 0.68%, 0.50%, 0.14%, 0 of the particles within half a spacing of a neighbour (a
    # few at the walls of the coarse tanks). Past a support of 2 the cubic spline pairs (59% at
    # 2.5 in the H200's tank); the bound sits between.
    paired = [float(r["paired"]) for r in rows]
    print(f"paired {paired}")
    assert max(paired) < 0.01, f"the tank's particles pair: {paired}"
    for k in range(1, len(rows)):
        assert e[k] < e[k - 1], f"the error grew from spacing {h[k-1]} to {h[k]}: {e[k-1]} -> {e[k]}"
    order = order_of(h, e)
    print(f"observed order {order:.2f}")
    # Measured 1.59 over spacings 0.02, 0.015, 0.0125, 0.01 (errors 2.10%, 1.75%, 0.97%, 0.75%
    # of rho0 g H; the small study once ended at 0.0075, 0.50%, order 1.56, a run 3x the 0.01's
    # that CI's 40 minutes no longer pay for):
    # between first order (the kernel's truncation near the free surface and the walls) and
    # second (its interior). A coarser 0.03 (5 particles across the tank) is off the asymptote
    # (11.6%) and left out.
    lo, hi = 1.4, 1.75
    assert lo <= order <= hi, f"observed order {order:.2f} outside [{lo}, {hi}]"


def dambreak(rows, h, e):
    for r in rows:
        # paired: recorded, not bounded: the surge's impacts bring particles together (3-7% of
        # them within half a spacing at these spacings), which is not the kernel's instability.
        for key in ("front_rms", "height_rms", "release_delay", "paired"):
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


def catenary(rows, h, e):
    # h: the stitches' length (1 / stitches along the strip).
    for k in range(1, len(rows)):
        assert e[k] < e[k - 1], f"the error grew from 1/{1 / h[k - 1]:g} to 1/{1 / h[k]:g}: {e}"
    order = order_of(h, e)
    print(f"against the catenary: largest deviations {e} of the span, observed order {order:.2f}")
    # Measured 0.202%, 0.0551%, 0.0228% of the span at 15, 30, 60 stitches: order 1.87 then
    # 1.27, 1.57 over the three. A chain of point masses lies on the catenary to second order in
    # its links; the floor it nears is the strip's stretch, which varies with the tension along
    # it (about 1%) where the reference takes it uniform, and the layers' thickness.
    assert e[-1] < 5e-4, f"the finest strip {100 * e[-1]:.3f}% of the span off the catenary"
    lo, hi = 1.4, 1.75
    assert lo <= order <= hi, f"observed order {order:.2f} outside [{lo}, {hi}]"


# A case: its resolution axis, its rows, and how its resolution reads as a length.
CASES = {"hydrostatic": ("spacing", 4, hydrostatic, float),
         "dambreak": ("spacing", 4, dambreak, float),
         "catenary": ("stitches", 3, catenary, lambda v: 1.0 / float(v))}


def main():
    case, out = sys.argv[1:3]
    axis, count, check, length = CASES[case]
    with open(os.path.join(out, f"{case}_{axis}.csv")) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == count, f"{len(rows)} rows, not {count}"
    for r in rows:
        for key in ("particles", "steps", "wall_s", "memory_mb", "device", "commit"):
            assert r.get(key), f"no {key} in {r}"
    assert os.path.getsize(os.path.join(out, f"{case}_{axis}.png")) > 10000, "no plot"
    h = [length(r["value"]) for r in rows]
    e = [float(r["error"]) for r in rows]
    check(rows, h, e)


if __name__ == "__main__":
    main()
