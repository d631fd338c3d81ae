#!/usr/bin/python3
"""P5's communication model: weak and strong scaling of the fluid step on 2-512 GPUs, on paper.

A step on P GPUs (one rank a GPU, N fluid particles a rank) costs
    T = t_p * (N + G) + 2 * (pack + transfer + latency)      (no overlap)
    T = t_p * (N + G) + 2 * max(0, pack + transfer + latency - t_p * N * f_interior)   (overlap)
where G is the rank's ghosts (all of them computed over, as built), and each of the step's two
refreshes (x, v before the density pass; rho, P before the forces) moves G * 16 B in float.
Calibration (docs/PERFORMANCE.md, P5):
  t_p     H100, 4M dam break with "verlet" lists: 3.33e9 particle-steps/s (P4 stage 14).
  G       ghost layers = width / dp = support (2) * (1 + skin 0.1) = 2.2 per face, on a cube
          of N particles a rank, faces/edges/corners shared by the rank's neighbours; scaled by
          `ghost_factor`, the measured ghosts of `knitflow plan --ranks N` on the 4M dam break
          over this geometric count (METIS's blocks are not planes).
  pack    bytes read and written by a gather/scatter kernel at 70% of the H100's 3.35 TB/s
          (NVIDIA H100 SXM5 datasheet), plus 2 launches of 4 us; no device pack kernel exists
          yet: the host path measured by bench/bench_halo is recorded beside it.
  links   NVLink 4: 450 GB/s a direction a GPU (H100 SXM5 datasheet: 900 GB/s total) within a
          node of 8; InfiniBand NDR 400 Gb/s = 50 GB/s a GPU (one ConnectX-7 a GPU, DGX H100)
          between nodes. Latency a message: 10 us within a node, 20 us between (NCCL p2p,
          assumed; P9 measures it).
Writes CSV and a PNG (jobs/studies/out/ by default)."""
import argparse
import csv
import math
import os

T_P = 1.0 / 3.33e9          # s a particle-step, H100, verlet lists, 4M dam break
LAYERS = 2.0 * 1.1          # ghost width / dp
BYTES_PER_GHOST = 16        # per refresh: (x, v) 24 B or (rho, P) 8 B in float: 32 B over 2
HBM = 3.35e12 * 0.7         # B/s achieved by a gather
LAUNCH = 4e-6
NVLINK, IB = 450e9, 50e9    # B/s a direction a GPU
LAT_NODE, LAT_NET = 10e-6, 20e-6
GPUS_PER_NODE = 8


def grid_of(p):
    """Ranks as a near-cubic grid (px, py, pz), px >= py >= pz."""
    best = None
    for px in range(1, p + 1):
        if p % px:
            continue
        for py in range(1, p // px + 1):
            if (p // px) % py:
                continue
            pz = p // px // py
            dims = sorted((px, py, pz), reverse=True)
            score = sum(dims) / 3 - min(dims)
            if best is None or score < best[0]:
                best = (score, tuple(dims))
    return best[1]


def neighbours(dims):
    """Neighbour sides along each split axis of an interior rank: 2, or 1 where the axis has 2."""
    return [0 if d == 1 else (1 if d == 2 else 2) for d in dims]


def ghosts(n, dims, factor):
    """Ghosts of an interior rank of a (px, py, pz) split into cubes of n particles: faces,
    edges and corners it shares with its neighbours, LAYERS deep."""
    side = n ** (1.0 / 3.0)
    s = neighbours(dims)
    faces = sum(s)
    edges = s[0] * s[1] + s[0] * s[2] + s[1] * s[2]
    corners = s[0] * s[1] * s[2]
    w = LAYERS
    g = faces * side * side * w + edges * side * w * w + corners * w ** 3
    return factor * g, faces + edges + corners


def step_time(n, p, factor, overlap):
    if p == 1:
        return T_P * n, 0.0, 0
    dims = grid_of(p)
    g, msgs = ghosts(n, dims, factor)
    b = g * BYTES_PER_GHOST
    pack = 2 * b / HBM + 2 * LAUNCH                       # gather out, scatter in
    bw, lat = (NVLINK, LAT_NODE) if p <= GPUS_PER_NODE else (IB, LAT_NET)
    # Messages to all neighbours are posted together: one latency, plus 2 us each to post.
    comm = pack + b / bw + lat + 2e-6 * msgs
    compute = T_P * (n + g)
    if overlap:
        interior = T_P * max(0.0, n - g)                   # particles a ghost away from the border
        hidden = min(comm, interior)
        return compute + 2 * (comm - hidden), g, msgs
    return compute + 2 * comm, g, msgs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ghost-factor", type=float, default=1.3,
                    help="measured ghosts over the geometric count (plan --ranks)")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "out"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = []
    ps = [1, 2, 8, 64, 512]
    for mode in ("weak", "strong"):
        for overlap in (False, True):
            for p in ps:
                n = 4e6 if mode == "weak" else 8e6 / p
                t, g, faces = step_time(n, p, a.ghost_factor, overlap)
                t1 = step_time(n if mode == "weak" else 8e6, 1, a.ghost_factor, overlap)[0]
                eff = t1 / t if mode == "weak" else t1 / t / p
                rows.append({"mode": mode, "overlap": int(overlap), "gpus": p,
                             "particles_per_gpu": int(n), "ghosts_per_gpu": int(g),
                             "step_ms": 1e3 * t, "speedup": t1 / t if mode == "strong" else p * t1 / t,
                             "efficiency": eff})
    path = os.path.join(a.out, "comm_model.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    for r in rows:
        print("{mode:6s} overlap={overlap} P={gpus:4d} N/GPU={particles_per_gpu:8d} ghosts={ghosts_per_gpu:7d} "
              "step {step_ms:7.3f} ms  speedup {speedup:7.2f}  efficiency {efficiency:5.3f}".format(**r))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for overlap, style in ((0, "--"), (1, "-")):
            wk = [r for r in rows if r["mode"] == "weak" and r["overlap"] == overlap]
            st = [r for r in rows if r["mode"] == "strong" and r["overlap"] == overlap]
            lab = "overlap" if overlap else "no overlap"
            ax[0].plot([r["gpus"] for r in wk], [r["efficiency"] for r in wk], style + "o", label=lab)
            ax[1].plot([r["gpus"] for r in st], [r["speedup"] for r in st], style + "o", label=lab)
        ax[1].plot(ps, ps, ":", color="grey", label="ideal")
        ax[0].axhline(0.9, color="grey", lw=0.5)
        ax[0].set(xscale="log", xlabel="GPUs", ylabel="weak-scaling efficiency (4M a GPU)",
                  ylim=(0.5, 1.02))
        ax[1].set(xscale="log", yscale="log", xlabel="GPUs", ylabel="speedup (8M dam break)")
        for x in ax:
            x.legend()
            x.grid(alpha=0.3)
        fig.suptitle("knitflow fluid step, communication model (H100, NVLink within 8, NDR between)")
        fig.tight_layout()
        fig.savefig(os.path.join(a.out, "comm_model.png"), dpi=120)
    except ImportError:
        print("matplotlib missing: no plot")
    print("wrote", path)


if __name__ == "__main__":
    main()
