#!/usr/bin/python3
"""Weak and strong scaling of the dam break over MPI ranks: runs `knitflow run` under mpiexec for
each rank count, reads each run's closing "done" line, and writes a CSV and a PNG.

  weak:   the same particles a rank at every rank count (the fluid block grows with the ranks)
  strong: the same total at every rank count

    jobs/studies/scaling.py --ranks 1,2 --per-rank 20000 --total 40000 --steps 100
    jobs/studies/scaling.py --ranks 1,2,4,8 --device cuda ...    # one rank a GPU (P9)

On this 2-core machine ranks share the cores (one OpenMP thread a rank); on a cluster, run it
inside an allocation (jobs/slurm/knitflow.sbatch shows the launch line). Efficiency is against
the first rank count of the list. Output: jobs/studies/out/scaling.{csv,png} by default."""
import argparse
import csv
import os
import re
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DONE = re.compile(r"done: (\d+) steps to t = \S+ s in ([\d.]+) s wall, ([\d.e+-]+) particle-steps/s")


def spacing_for(particles):
    """scenes/dambreak.toml's block is 0.2 x 0.2 x 0.4 m: dp for a given fluid count."""
    return (0.016 / particles) ** (1.0 / 3.0)


def run(exe, ranks, particles, steps, device, threads, extra):
    cmd = ["mpiexec", "-n", str(ranks), "--oversubscribe", exe, "run",
           os.path.join(ROOT, "scenes", "dambreak.toml"), "--device", device,
           "--threads", str(threads), "--set", "output.enabled=false",
           "--set", "solver.max_steps=%d" % steps,
           "--set", "fluid.spacing=%.8g" % spacing_for(particles)] + extra
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    out = subprocess.run(cmd, env=env, capture_output=True, text=True)
    m = DONE.search(out.stdout + out.stderr)
    if out.returncode != 0 or not m:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), (out.stdout + out.stderr)[-2000:]))
    return int(m.group(1)), float(m.group(2)), float(m.group(3))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--per-rank", type=float, default=20000, help="weak series: fluid particles a rank")
    ap.add_argument("--total", type=float, default=40000, help="strong series: fluid particles in all")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--threads", type=int, default=1, help="OpenMP threads a rank")
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "cpu", "apps", "knitflow"))
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "out"))
    ap.add_argument("--set", action="append", default=[], help="extra scene override (repeatable)")
    a = ap.parse_args()
    extra = sum((["--set", s] for s in a.set), [])
    ranks = [int(r) for r in a.ranks.split(",")]
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for series in ("weak", "strong"):
        base = None
        for r in ranks:
            n = a.per_rank * r if series == "weak" else a.total
            steps, wall, rate = run(a.exe, r, n, a.steps, a.device, a.threads, extra)
            per_step = wall / steps
            if base is None:
                base = (r, per_step)
            # weak: the same work a rank, so ideal time is constant; strong: ideal time ~ 1 / r.
            eff = base[1] / per_step if series == "weak" else base[1] * base[0] / (per_step * r)
            rows.append({"series": series, "ranks": r, "particles": int(n), "steps": steps,
                         "wall_s": wall, "ms_per_step": 1e3 * per_step, "particle_steps_per_s": rate,
                         "efficiency": eff})
            print("{series:6s} ranks {ranks:3d} particles {particles:9d} {ms_per_step:9.2f} ms/step "
                  "{particle_steps_per_s:.3e} particle-steps/s efficiency {efficiency:.3f}".format(**rows[-1]),
                  flush=True)
    path = os.path.join(a.out, "scaling.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        for series, style in (("weak", "o-"), ("strong", "s--")):
            sel = [r for r in rows if r["series"] == series]
            ax.plot([r["ranks"] for r in sel], [r["efficiency"] for r in sel], style, label=series)
        ax.axhline(1.0, color="grey", lw=0.5)
        ax.set(xlabel="ranks", ylabel="parallel efficiency", ylim=(0, 1.1),
               title="knitflow dam break, %s, %d thread(s) a rank" % (a.device, a.threads))
        ax.set_xscale("log", base=2)
        ax.set_xticks(ranks)
        ax.set_xticklabels([str(r) for r in ranks])
        ax.minorticks_off()
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join(a.out, "scaling.png"), dpi=120)
    except ImportError:
        print("matplotlib missing: no plot")
    print("wrote", path)


if __name__ == "__main__":
    main()
