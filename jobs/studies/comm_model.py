#!/usr/bin/python3
"""The communication model of the fluid step on P GPUs (one rank a GPU), calibrated by measured
runs, and its predictions for weak and strong scaling at 2 to 512 GPUs.

P5's model (kept for comparison, "p5" in the output) priced a step as compute over owned and ghost
particles plus two halo refreshes at the HBM floor for packing, NVLink/InfiniBand bandwidth and an
assumed 10/20 us latency, with the refreshes hidden behind the interior. P9's runs on 1, 2 and 4
H100s (jobs/gpu/p9_gpus.sh; CSVs in jobs/studies/data/) showed what it missed, and the model is now

    T(P, N) = k * T1(N + c G) + F + X(P)

  T1  one GPU's step at N fluid particles. Where the measured runs hold one-GPU steps at three or
      more sizes (docs/data/p9_h200x2_2026-11-30/one_gpu_sizes.csv: 0.25M to 8M on an H200), the
      curve through them (linear between sizes, the end segments' lines beyond); else
      T1(N) = a + b N fitted on the one-GPU rows. A particle-step costs more in the smaller dam
      breaks (1M: 0.42 ms, 2.4e9 particle-steps/s; 8M: 2.47 ms, 3.2e9): the GPU's tails and
      fixed work (not the coarser tank's walls: a rank of the 8M split, its pair passes timed
      alone by ncu, costs a particle what the 1M dam break does; docs/PERFORMANCE.md, "P5: a
      piece of the split alone"). "A free split" in the output is T1(N) / T1(N / P), what a
      split costing nothing would reach with its pieces at the smaller dam breaks' rate. a and
      b (a fixed cost a step and a particle-step's cost) are printed either way.
  F   a cost a step every rank of a split pays whatever its size: 0 unless --split-fixed-us
      (a what-if: the density's border launch, one warp's walk, ~30 us by ncu). Since
      2026-12-03 the interior runs beside that launch (a side stream) instead of after it:
      --border-hidden-us H takes H a step out of the calibration runs' steps (their code paid
      it) for k's fit and leaves it out of the predictions.
  k   the split's inflation of a rank's step (1 on one GPU): the passes split into interior and
      border launches, the rows' lists, the imbalance left by METIS, the ghosts' share of the
      sort. Fitted on the multi-GPU runs: the mean of (T - F - X) / T1(N + c G).
  G   ghosts of a rank: the geometric count (a cube a rank, LAYERS deep on each face, edge and
      corner it shares) times `ghost_factor` (1.3: `knitflow plan --ranks N` on the 4M dam break).
      A ghost costs a share c of an owned particle's step: it is sorted, listed, drifted and
      kicked, but the passes whose results its owner sends skip it. So T1(N + c G), not
      T1(N + G). In the calibration runs' code (P9, 2026-11-30) the density pass skipped the
      ghosts (overlapped over the owned rows) and the forces pass did not: c = 1 - 0.29 = 0.71;
      since 2026-12-02 the forces pass skips them too: c = 1 - 0.29 - 0.39 = 0.32 (the two
      passes' shares of one H200's 1M dam break step, 126 and 168 of 431 us: "The one-GPU
      curve by stage"). The fit takes the runs' c, the predictions --ghost-cost.
  X   the step's exchanges as they show on rank 0's wall ("split" line: migration, refreshes):
      x0 + x1 * peers + w * T1(N + c G) + bytes / link. Each refresh is a meeting point: it waits
      for the slower rank's pass of that stage, and those waits grow with the passes (w, the
      stages' imbalance as a share of a rank's step); x0 is what an exchange costs regardless
      (packing and unpacking launches, NCCL's latency, the streams' events). x0 and w are fitted
      on the measured exchanges at two or more sizes a rank (2 x H200: 4M and 16M a rank, 0.19
      and 0.52 ms; a constant X had priced 16M a rank at 0.20 ms and so 32M on 2 GPUs at 1.99x
      against 1.84x measured); x1 where runs with more peers exist. The calibration runs'
      partitions had METIS's 3% allowance (landing at 1.029 on the 8M dam break); since
      2026-12-06 a fluid-only split gets 1% (1.009): runs with it would refit w. Between nodes
      (P > 8) each of the step's E = 3 exchanges pays the network's latency over NVLink's, and
      the bytes cross InfiniBand.

Links: NVLink 4, 450 GB/s a direction a GPU (NVIDIA H100 SXM5 data sheet: 900 GB/s total), 8 GPUs
a node (the measured host: 4 H100 SXM, NV18 between every pair); InfiniBand NDR 400 Gb/s = 50 GB/s
a GPU (DGX H100: one ConnectX-7 a GPU). Latency between nodes: 20 us a message over 10 us within
(assumed; no host pair was lent to measure it).

    jobs/studies/comm_model.py                                  # the documented calibration
    jobs/studies/comm_model.py --split-fixed-us 30              # the density border's latency
    jobs/studies/comm_model.py --border-hidden-us 30            # ... hidden (the side stream)
    jobs/studies/comm_model.py --measured a.csv,b.csv --out DIR
    jobs/studies/comm_model.py --one-gpu docs/data/p5_h100_2026-12-05d/one_gpu_sizes_h100.csv
                                                                # an H100's T1 (the H200 pair's fit)

Without arguments it gives docs/PERFORMANCE.md's current figures: calibrated by the six CSVs of
docs/data/p9_h200x2_2026-11-30/ (2 x H200, NCCL), the exchanges' fixed cost 30 us lower than
those runs' (the walls' refresh they paid is gone since), a ghost at GHOST_COST_NOW. The older
H100 runs (jobs/studies/data/p9_*.csv, code of 2026-11-29) calibrate it with
`--measured "$(ls jobs/studies/data/p9_*.csv | paste -sd,)" --x0-less-us 0`.

Under each strong series it prints, for P5's goals (1.8x on 2 GPUs, 6x on 8), the one-GPU step
a rank's work (its fluid and its ghosts' share) would have to take for the split to reach the
goal with k, w and x0 as calibrated (the model solved for T1), beside what the one-GPU curve
gives: how far the small sizes' step is from what the goal asks.

Writes DIR/comm_model.csv (predictions), DIR/comm_model_fit.csv (each measured run against the
model) and DIR/comm_model.png."""
import argparse
import csv
import os

HERE = os.path.dirname(os.path.abspath(__file__))
LAYERS = 2.0 * 1.1            # ghost width / dp: support 2 h ... in dp, with the lists' skin
GHOST_COST_RUNS = 0.71        # a ghost's share of a particle-step in the calibration runs' code
GHOST_COST_NOW = 0.32         # ... since the forces pass skips the ghosts (docstring)
BYTES_PER_GHOST = 16          # a refresh: (x, v) 24 B or (rho, P) 8 B in float; 32 B over 2
EXCHANGES = 3                 # a step: migration (and its ghosts) and two refreshes
STRONG_GOALS = [(2, 1.8), (8, 6.0)]  # P5's strong goals on paper: GPUs, speedup
NVLINK, IB = 450e9, 50e9      # B/s a direction a GPU
LAT_NODE, LAT_NET = 10e-6, 20e-6
GPUS_PER_NODE = 8
# The documented calibration (main()'s defaults): 2 x H200 runs of 2026-11-30, and the walls'
# refresh those runs paid (30-31 us a step on rank 0) removed from the code since.
CALIBRATION = os.path.join(HERE, "..", "..", "docs", "data", "p9_h200x2_2026-11-30")
CALIBRATION_CSVS = ["one_gpu_sizes.csv", "weak_4M_steady_r1.csv", "weak_4M_steady_r2.csv",
                    "strong_8M_steady_r1.csv", "strong_8M_steady_r2.csv", "strong_32M_steady.csv"]
X0_LESS_US = 30.0
# P5's inputs, for its column of the output.
P5_T_P, P5_HBM, P5_LAUNCH = 1.0 / 3.33e9, 3.35e12 * 0.7, 4e-6


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


def ghosts(n, p, factor):
    """Ghosts and peers of an interior rank of a split of P cubes of n particles: the faces, edges
    and corners it shares with its neighbours, LAYERS deep."""
    if p == 1:
        return 0.0, 0
    s = [0 if d == 1 else (1 if d == 2 else 2) for d in grid_of(p)]
    side = n ** (1.0 / 3.0)
    faces = sum(s)
    edges = s[0] * s[1] + s[0] * s[2] + s[1] * s[2]
    corners = s[0] * s[1] * s[2]
    w = LAYERS
    g = faces * side * side * w + edges * side * w * w + corners * w ** 3
    return factor * g, faces + edges + corners


def lstsq2(xs, ys):
    """y = c0 + c1 x by least squares (one point: c1 = 0)."""
    n = len(xs)
    if n == 1 or len(set(xs)) == 1:
        return sum(ys) / n, 0.0
    mx, my = sum(xs) / n, sum(ys) / n
    c1 = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    return my - c1 * mx, c1


class Model:
    def __init__(self, rows, ghost_factor, ghost_cost=GHOST_COST_RUNS, split_fixed=0.0,
                 border_hidden=0.0):
        self.gf = ghost_factor
        self.fixed = split_fixed  # seconds a step a split rank pays whatever its size
        self.hidden = border_hidden  # ... that the runs paid and the predictions' code does not
        self.gc = ghost_cost  # the fit's; main() sets the predictions' after it
        one = [r for r in rows if r["ranks"] == 1]
        many = [r for r in rows if r["ranks"] > 1]
        if not one or not many:
            raise SystemExit("comm_model: the measured runs need 1-GPU and multi-GPU rows")
        # T(1, N) = a + b N
        self.a, self.b = lstsq2([r["fluid"] for r in one], [r["ms_per_step"] * 1e-3 for r in one])
        # T1: the measured curve where three or more sizes were run (runs of one size averaged)
        sizes = {}
        for r in one:
            sizes.setdefault(round(r["fluid"], -3), []).append(r["ms_per_step"] * 1e-3)
        self.curve = sorted((n, sum(t) / len(t)) for n, t in sizes.items())
        if len(self.curve) < 3:
            self.curve = None
        # X = x0 + x1 peers + w T1(N + c G) + bytes / NVLink: x0 and w from the sizes a rank, x1
        # from the peers (one of the two where the runs vary only the other; both varying is
        # fitted one after the other, sizes first).
        self.x1 = self.w = 0.0
        rest, size, peer = [], [], []
        for r in many:
            n = r["fluid"] / r["ranks"]
            g, peers = ghosts(n, r["ranks"], self.gf)
            rest.append(r["exchange_ms"] * 1e-3 - 2 * g * BYTES_PER_GHOST / NVLINK)
            size.append(self.one_gpu(n + self.gc * g))
            peer.append(peers)
        self.x0, self.w = lstsq2(size, rest)
        if self.w < 0:  # waits that shrink as the passes grow: noise (the H100 runs), not a cost
            self.x0, self.w = sum(rest) / len(rest), 0.0
        if len(set(peer)) > 1:
            _, self.x1 = lstsq2(peer, [y - self.w * t for y, t in zip(rest, size)])
            self.x0 = sum(y - self.w * t - self.x1 * q for y, t, q in zip(rest, size, peer)) / len(rest)
        ks = []
        for r in many:
            n = r["fluid"] / r["ranks"]
            g, _ = ghosts(n, r["ranks"], self.gf)
            ks.append((r["ms_per_step"] * 1e-3 - self.exchange(n, r["ranks"]) - self.fixed -
                       self.hidden) /
                      self.one_gpu(n + self.gc * g))
        self.k = sum(ks) / len(ks)

    def use_one_gpu(self, one):
        """T1 from other one-GPU rows (another GPU), after the fit: k and w are shares of a
        rank's step and x0 a fixed cost, so they carry over; T1 is what the GPU sets."""
        sizes = {}
        for r in one:
            sizes.setdefault(round(r["fluid"], -3), []).append(r["ms_per_step"] * 1e-3)
        self.curve = sorted((n, sum(t) / len(t)) for n, t in sizes.items())
        if len(self.curve) < 3:
            raise SystemExit("comm_model: --one-gpu needs one-GPU rows at three or more sizes")
        self.a, self.b = lstsq2([r["fluid"] for r in one], [r["ms_per_step"] * 1e-3 for r in one])

    def one_gpu(self, n):
        """Seconds a step with n fluid particles on one GPU (T1)."""
        c = self.curve
        if not c:
            return self.a + self.b * n
        i = 1
        while i < len(c) - 1 and n > c[i][0]:
            i += 1
        (n0, t0), (n1, t1) = c[i - 1], c[i]
        return t0 + (t1 - t0) * (n - n0) / (n1 - n0)

    def rank_work(self, n, p):
        """The particles a rank's step costs as on one GPU: its n fluid and its ghosts' share."""
        return n + self.gc * ghosts(n, p, self.gf)[0]

    def exchange(self, n, p, t1=None):
        """The exchanges of a rank's step; t1: its work's one-GPU step (None: from the curve)."""
        if p == 1:
            return 0.0
        g, peers = ghosts(n, p, self.gf)
        if t1 is None:
            t1 = self.one_gpu(self.rank_work(n, p))
        x = self.x0 + self.x1 * peers + self.w * t1 + 2 * g * BYTES_PER_GHOST / NVLINK
        if p > GPUS_PER_NODE:
            x += EXCHANGES * (LAT_NET - LAT_NODE) + 2 * g * BYTES_PER_GHOST * (1 / IB - 1 / NVLINK)
        return x

    def step(self, n, p, runs=False, t1=None):
        """Seconds a step with n fluid particles a rank on p GPUs (runs: in the calibration
        runs' code, which paid `hidden`); t1: the rank's work's one-GPU step (None: from the
        curve)."""
        if p == 1:
            return self.one_gpu(n) if t1 is None else t1
        if t1 is None:
            t1 = self.one_gpu(self.rank_work(n, p))
        return (self.k * t1 + self.fixed + (self.hidden if runs else 0.0) +
                self.exchange(n, p, t1))

    def rank_step_for(self, total, p, goal):
        """The one-GPU step of a rank's work (rank_work) for a split of `total` fluid over p GPUs
        to reach `goal` times one GPU's step: step() is linear in it, so solved from two of
        its values."""
        n, target = total / p, self.one_gpu(total) / goal
        at0, at1 = self.step(n, p, t1=0.0), self.step(n, p, t1=1.0)
        return (target - at0) / (at1 - at0)


def p5_step(n, p, factor):
    """P5's model with the overlap (its docstring's formula, kept to show what P9 changed)."""
    if p == 1:
        return P5_T_P * n
    g, msgs = ghosts(n, p, factor)
    b = g * BYTES_PER_GHOST
    bw, lat = (NVLINK, LAT_NODE) if p <= GPUS_PER_NODE else (IB, LAT_NET)
    comm = 2 * b / P5_HBM + 2 * P5_LAUNCH + b / bw + lat + 2e-6 * msgs
    hidden = min(comm, P5_T_P * max(0.0, n - g))
    return P5_T_P * (n + g) + 2 * (comm - hidden)


def read_rows(paths):
    rows = []
    for path in paths:
        with open(path) as f:
            for r in csv.DictReader(f):
                if r.get("scene", "dambreak") != "dambreak":
                    continue
                rows.append({"file": os.path.basename(path), "series": r["series"],
                             "ranks": int(r["ranks"]), "fluid": float(r["fluid"]),
                             "ms_per_step": float(r["ms_per_step"]),
                             "exchange_ms": float(r.get("exchange_ms") or 0)})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--measured", default=",".join(os.path.join(CALIBRATION, c) for c in CALIBRATION_CSVS),
                    help="scaling.py CSVs (comma-separated) to calibrate by")
    ap.add_argument("--ghost-factor", type=float, default=1.3,
                    help="measured ghosts over the geometric count (knitflow plan --ranks)")
    ap.add_argument("--x0-less-us", type=float, default=X0_LESS_US,
                    help="a what-if: the exchanges' fixed cost a step lowered by this many us after "
                         "the fit (a change measured where the model's runs were not: a refresh "
                         "fewer); the predictions say so")
    ap.add_argument("--split-fixed-us", type=float, default=0.0,
                    help="a what-if: a cost a step every rank of a split pays whatever its size "
                         "(the density's border launch: ~30 us, one warp's walk, measured by ncu "
                         "on 8 ranks of the 8M dam break), taken out of k's fit")
    ap.add_argument("--border-hidden-us", type=float, default=0.0,
                    help="a what-if: a cost a step the calibration runs' split ranks paid and the "
                         "code now hides (the density's border launch, ~30 us, now beside the "
                         "interior on a side stream), taken out of k's fit, not added back")
    ap.add_argument("--ghost-cost-runs", type=float, default=GHOST_COST_RUNS,
                    help="a ghost's share of a particle-step in the measured runs' code")
    ap.add_argument("--ghost-cost", type=float, default=GHOST_COST_NOW,
                    help="the same in the code the predictions are for")
    ap.add_argument("--one-gpu", default="",
                    help="CSVs (comma-separated) whose one-GPU rows give the predictions' T1 "
                         "(another GPU's curve: scaling.py --ranks 1 --series strong --total "
                         "SIZES); k, x0 and w stay the calibration runs' (shares of a rank's "
                         "step, and a fixed cost)")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = read_rows([p for p in a.measured.split(",") if p])
    m = Model(rows, a.ghost_factor, a.ghost_cost_runs, a.split_fixed_us * 1e-6,
              a.border_hidden_us * 1e-6)
    if a.border_hidden_us:
        print("what-if: the runs' split ranks paid %.1f us a step that the code now hides "
              "(out of k's fit, not in the predictions)" % a.border_hidden_us)
    if a.split_fixed_us:
        print("what-if: a split rank pays %.1f us a step whatever its size (out of k's fit)"
              % a.split_fixed_us)
    if a.x0_less_us:
        print("what-if: x0 lowered by %.1f us a step after the fit (not measured by these runs)"
              % a.x0_less_us)
    print("calibrated: a = %.1f us a step, b = %.3f ns a particle-step (%.3e particle-steps/s), "
          "k = %.3f, exchanges x0 = %.1f us + %.1f us a peer + %.3f of a rank's step; T1 %s"
          % (m.a * 1e6, m.b * 1e9, 1 / m.b, m.k, m.x0 * 1e6, m.x1 * 1e6, m.w,
             "through %d measured sizes" % len(m.curve) if m.curve else "= a + b N"))

    fit = []
    print("\nmeasured against the model (and P5's):")
    for r in rows:
        n = r["fluid"] / r["ranks"]
        t = m.step(n, r["ranks"], runs=True)
        fit.append({"series": r["series"], "gpus": r["ranks"], "fluid": int(r["fluid"]),
                    "measured_ms": r["ms_per_step"], "model_ms": 1e3 * t,
                    "p5_model_ms": 1e3 * p5_step(n, r["ranks"], a.ghost_factor),
                    "measured_exchange_ms": r["exchange_ms"],
                    "model_exchange_ms": 1e3 * m.exchange(n, r["ranks"])})
        print("  {series:11s} P={gpus} fluid {fluid:9d}: measured {measured_ms:6.3f} ms, model "
              "{model_ms:6.3f} ms, P5 {p5_model_ms:6.3f} ms | exchanges {measured_exchange_ms:.3f} "
              "against {model_exchange_ms:.3f} ms".format(**fit[-1]))
    with open(os.path.join(a.out, "comm_model_fit.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(fit[0].keys()))
        w.writeheader()
        w.writerows(fit)

    m.x0 -= a.x0_less_us * 1e-6  # after the fit's comparison above: the runs had it
    m.gc = a.ghost_cost  # likewise: the runs' ghosts cost what their code made them
    if a.one_gpu:
        m.use_one_gpu([r for r in read_rows([p for p in a.one_gpu.split(",") if p])
                       if r["ranks"] == 1])
        print("\nthe predictions' T1: %s (%d sizes: %s ms a step at %s fluid)"
              % (a.one_gpu, len(m.curve), ", ".join("%.3f" % (t * 1e3) for _, t in m.curve),
                 ", ".join("%.2gM" % (n / 1e6) for n, _ in m.curve)))
    print("\na ghost costs %.2f of a particle-step in the measured runs, %.2f in the predictions"
          % (a.ghost_cost_runs, a.ghost_cost))
    ps = [1, 2, 4, 8, 64, 512]
    cases = [("weak 4M a GPU", lambda p: 4e6), ("strong 8M", lambda p: 8e6 / p),
             ("strong 32M", lambda p: 32e6 / p)]
    pred = []
    print("\npredictions (efficiency for weak, speedup for strong; P5's model in brackets):")
    for name, n_of in cases:
        t1, p51 = m.step(n_of(1) if name.startswith("weak") else n_of(1), 1), p5_step(n_of(1), 1, a.ghost_factor)
        line = []
        for p in ps:
            t, tp5 = m.step(n_of(p), p), p5_step(n_of(p), p, a.ghost_factor)
            value = t1 / t if name.startswith("weak") else t1 / t
            v5 = p51 / tp5
            pred.append({"case": name, "gpus": p, "particles_per_gpu": int(n_of(p)),
                         "step_ms": 1e3 * t, "exchange_ms": 1e3 * m.exchange(n_of(p), p),
                         "efficiency" if name.startswith("weak") else "speedup": value,
                         "p5_model": v5})
            line.append("P=%d %.2f (%.2f)" % (p, value, v5))
        print("  %-14s %s" % (name, "  ".join(line)))
        if name.startswith("strong"):
            print("  %-14s %s" % ("  a free split", "  ".join(
                "P=%d %.2f" % (p, m.one_gpu(n_of(1)) / m.one_gpu(n_of(p))) for p in ps)))
            for p, goal in STRONG_GOALS:
                work = m.rank_work(n_of(p), p)
                need, now = m.rank_step_for(n_of(1), p, goal), m.one_gpu(work)
                print("  %-14s P=%d: %.1fx (one GPU's %.3f ms / %.1f) needs a rank's one-GPU step "
                      "(%.2fM: its fluid and its ghosts' share) of %.3f ms; the curve gives %.3f "
                      "(%+.0f%%)" % ("  the goal", p, goal, m.one_gpu(n_of(1)) * 1e3, goal,
                                    work / 1e6, need * 1e3, now * 1e3,
                                    100 * (now / need - 1)))
    keys = ["case", "gpus", "particles_per_gpu", "step_ms", "exchange_ms", "efficiency", "speedup", "p5_model"]
    with open(os.path.join(a.out, "comm_model.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(pred)

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: no plot")
        return
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    wk = [r for r in pred if r["case"].startswith("weak")]
    ax[0].plot(ps, [r["efficiency"] for r in wk], "-", color="C0", label="model (P9-calibrated)")
    ax[0].plot(ps, [r["p5_model"] for r in wk], ":", color="C0", label="P5's model")
    meas = [f for f in fit if f["series"] == "weak"]
    if meas:
        base = [f for f in meas if f["gpus"] == 1][0]
        ax[0].plot([f["gpus"] for f in meas],
                   [base["measured_ms"] / f["measured_ms"] * (f["fluid"] / f["gpus"]) / base["fluid"] for f in meas],
                   "o", color="C0", label="measured")
    ax[0].axhline(0.9, color="grey", lw=0.5)
    ax[0].axhline(0.85, color="grey", lw=0.5, ls="--")
    ax[0].set(xscale="log", xlabel="GPUs", ylabel="weak-scaling efficiency (4M fluid a GPU)", ylim=(0.3, 1.05))
    for i, name in enumerate(("strong 8M", "strong 32M")):
        st = [r for r in pred if r["case"] == name]
        c = "C%d" % (i + 1)
        ax[1].plot(ps, [r["speedup"] for r in st], "-", color=c, label=name + " model")
        ax[1].plot(ps, [r["p5_model"] for r in st], ":", color=c, label=name + " P5's model")
        n_of = dict(cases)[name]
        ax[1].plot(ps, [m.one_gpu(n_of(1)) / m.one_gpu(n_of(p)) for p in ps], "--", color=c, lw=0.8,
                   label=name + ", a free split")
        meas = [f for f in fit if f["series"] == name]
        if meas:
            base = [f for f in meas if f["gpus"] == 1][0]
            ax[1].plot([f["gpus"] for f in meas], [base["measured_ms"] / f["measured_ms"] for f in meas],
                       "o", color=c, label=name + " measured")
    ax[1].plot(ps, ps, ":", color="grey", label="ideal")
    ax[1].set(xscale="log", yscale="log", xlabel="GPUs", ylabel="speedup over one GPU")
    for x in ax:
        x.legend(fontsize=7)
        x.grid(alpha=0.3)
    fig.suptitle("knitflow dam break on P GPUs: measured and the calibrated model (NVLink within 8, NDR between)")
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "comm_model.png"), dpi=120)
    print("wrote", os.path.join(a.out, "comm_model.csv"))


if __name__ == "__main__":
    main()
