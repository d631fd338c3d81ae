#!/usr/bin/python3
"""knit_cases.lucas_washburn (the wicking study's reference, P7) against the closed form of
h' = A / h - B from h0 at t0: t - t0 = -(h - h0) / B - (A / B^2) ln((A - B h) / (A - B h0)),
on the wicking scene's own coefficients; and a start at h0 = 0, where the equation is singular,
refused (a step from there had gone below the pool and on down: the full studies' negative
errors). Usage: test_lucas_washburn.py"""
import math
import os
import sys
import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "jobs", "studies"))
import knit_cases  # noqa: E402


def main():
    with open(os.path.join(HERE, "..", "..", "scenes", "wicking.toml"), "rb") as f:
        scene = tomllib.load(f)
    cap, fl = scene["capillary"], scene["fluid"]
    kappa, phi, mu = cap["permeability"], cap["porosity"], max(fl["viscosity"], 1e-6)
    g = -scene["simulation"]["gravity"][2]
    pc0 = cap["sigma"] * knit_cases.leverett_j(0.0) / math.sqrt(kappa / phi)
    a, b = kappa * pc0 / (mu * phi), kappa * fl.get("rest_density", 1000.0) * g / (mu * phi)
    h0, t0 = 0.004, 0.1
    times = np.linspace(0.15, 1.2, 22)
    h, prefactor = knit_cases.lucas_washburn(h0, t0, times, scene)
    assert abs(prefactor - math.sqrt(2 * a)) <= 1e-12 * prefactor
    closed = t0 - (h - h0) / b - a / b**2 * np.log((a - b * h) / (a - b * h0))
    # The height the closed form's time error stands for: dt * h'(h). The midpoint rule's
    # 110,000 steps of 10 us leave 1.5e-12 m (measured 2026-12-06: the sums' rounding and the
    # rule's own error alike); a forward Euler step in its place leaves 6e-8 m.
    worst = float(np.max(np.abs(closed - times) * np.abs(a / h - b)))
    print(f"Lucas-Washburn: heights {h[0]:.5f} to {h[-1]:.5f} m; worst against the closed form "
          f"{worst:.2e} m (equilibrium {a / b:.4f} m)")
    assert np.all(np.diff(h) > 0) and h[-1] < a / b, "the front rises toward A / B"
    assert worst < 1e-11, worst
    for bad in (0.0, -1e-3):
        try:
            knit_cases.lucas_washburn(bad, t0, times, scene)
        except ValueError:
            continue
        raise AssertionError(f"a start at {bad} m was integrated")
    print("ok")


if __name__ == "__main__":
    main()
