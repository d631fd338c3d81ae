#!/usr/bin/python3
"""fluid_cases.paired_fraction (the studies' count of particles within half a spacing of a
neighbour, P7) against a brute-force count over every pair: a lattice, the lattice with a few
particles pushed onto neighbours, coincident pairs, and random points at several densities
(cells holding many particles). Usage: test_paired_fraction.py"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "jobs", "studies"))
import fluid_cases  # noqa: E402


def brute(x, spacing):
    d2 = ((x[:, None, :] - x[None, :, :]) ** 2).sum(axis=2)
    np.fill_diagonal(d2, np.inf)
    return float((d2.min(axis=1) < (0.5 * spacing) ** 2).mean())


def main():
    rng = np.random.default_rng(7)
    dp = 0.01
    g = np.arange(12) * dp
    lattice = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3) + 0.3
    assert fluid_cases.paired_fraction(lattice, dp) == 0.0, "a lattice has no pairs"
    pushed = lattice.copy()
    moved = rng.choice(len(pushed), 40, replace=False)
    # Each moved particle to 0.2-0.45 dp of its right-hand neighbour (some pairs share a cell,
    # some straddle a cell face).
    pushed[moved, 0] += dp * rng.uniform(0.55, 0.8, len(moved))
    coincident = np.vstack([lattice, lattice[:25]])
    cases = [("pushed", pushed), ("coincident", coincident)]
    for n, side in ((800, 0.2), (1500, 0.1), (1500, 0.03)):  # ~1e-5 to ~0.06 particles a cell
        cases.append((f"random {n} in {side} m", rng.uniform(0, side, (n, 3))))
    for name, x in cases:
        got, want = fluid_cases.paired_fraction(x, dp), brute(x, dp)
        print(f"{name}: {got:.4f} (brute force {want:.4f})")
        assert got == want, f"{name}: {got} against {want}"
        assert 0 < want < 1 or name.startswith("random 1500 in 0.03"), f"{name}: {want} tests little"
    print("paired_fraction: all cases as brute force")


if __name__ == "__main__":
    main()
