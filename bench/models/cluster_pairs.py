#!/usr/bin/env python3
"""How many pairs a cluster-pair forces pass would compute, against the lists it would replace.

A jittered lattice (spacing dp = 1, jitter +-0.15) is put in the fluid's sort order (cells of
h + s in rows along x, then the Morton code of 4 x 4 x 4 sub-cells within each cell) and cut into
clusters of C consecutive particles. A cluster-pair pass computes every pair of two clusters whose
bounding boxes lie within h + s; a list holds only the pairs within h + s. Interior clusters only.
The column's support h = 3.464 dp and skin s = 0.1 h. Needs numpy (system python3).

Output (2026-11-24): computed / listed pairs 3.07 (C = 4), 4.56 (8), 7.66 (16), 14.3 (32); so
even with each pair computed once (half), a cluster pass evaluates 1.5-2.3x the list's pairs.
"""
import numpy as np

rng = np.random.default_rng(1)
h = 3.464
reach = 1.1 * h  # h + s
n = 36
g = np.stack(np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij"), -1)
x = g.reshape(-1, 3) + 0.5 + rng.uniform(-0.15, 0.15, (n**3, 3))
cell = np.floor(x / reach).astype(int)
sub = np.floor((x / reach - cell) * 4).astype(int).clip(0, 3)


def spread(v):
    out = np.zeros_like(v)
    for b in range(2):
        out |= ((v >> b) & 1) << (3 * b)
    return out


morton = spread(sub[:, 0]) | (spread(sub[:, 1]) << 1) | (spread(sub[:, 2]) << 2)
nc = cell.max(0) + 1
key = ((cell[:, 2] * nc[1] + cell[:, 1]) * nc[0] + cell[:, 0]) * 64 + morton
x = x[np.argsort(key, kind="stable")]
for size in (4, 8, 16, 32):
    m = len(x) // size
    xc = x[: m * size].reshape(m, size, 3)
    lo, hi = xc.min(1), xc.max(1)
    centre = (lo + hi) / 2
    inner = np.all((centre > 2.5 * reach) & (centre < n - 2.5 * reach), axis=1)
    computed, listed, within = [], [], []
    for i in np.where(inner)[0][::7]:
        gap = np.maximum(0, np.maximum(lo - hi[i], lo[i] - hi))
        js = np.where(np.sqrt((gap**2).sum(1)) < reach)[0]
        computed.append(len(js) * size)
        pts = xc[js].reshape(-1, 3)
        for p in xc[i]:
            r = np.sqrt(((pts - p) ** 2).sum(1))
            listed.append((r < reach).sum())
            within.append((r < h).sum())
    print(f"clusters of {size}: {np.mean(computed):.0f} pairs computed a particle, "
          f"{np.mean(listed):.0f} listed (h + s), {np.mean(within):.0f} within h: "
          f"computed / listed {np.mean(computed) / np.mean(listed):.2f}")
