#!/usr/bin/python3
"""Weak and strong scaling over MPI ranks: runs `knitflow run` under mpiexec for each rank count,
reads each run's closing "done" and "split" lines, and writes a CSV and a PNG.

  weak:   the same particles a rank at every rank count (the dam break's fluid block is made
          finer; the pour's fluid finer and its knit square knitted with more stitches)
  strong: the same total at every rank count, for each total of --total (dam break only)

    jobs/studies/scaling.py --ranks 1,2 --per-rank 20000 --total 40000 --steps 100
    jobs/studies/scaling.py --ranks 1,2,4 --device cuda --per-rank 4e6 --total 8e6,32e6  # P9
    jobs/studies/scaling.py --scene pour --series weak --ranks 1,2,4 --device cuda
    jobs/studies/scaling.py --ranks 1,2 --device cuda --series weak --per-rank 4e6 --steps 300,1500

With two step counts (--steps A,B) each case runs twice and its step is the marginal one, the wall
difference over the B - A steps between: the start (NCCL's connections, the first lists, the first
steps' larger sorts) cancels; the split's figures are then the longer run's.

The step's communication (rank 0's exchanges, migration, ghost refreshes, rebalancing, the dt
all-reduce, packing) comes from the "split" line, in ms a step.

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
SPLIT = re.compile(r"split \(rank 0 of \d+, (\w+)\): exchanges ([\d.]+) s, [\d.]+% of the wall: fluid "
                   r"migration and ghosts ([\d.]+) s, ghost refreshes ([\d.]+) s, balance ([\d.]+) s, "
                   r"knit ghosts ([\d.]+) s, the step size's all-reduce ([\d.]+) s; "
                   r"packing rows ([\d.]+) s")
FLUID = re.compile(r"particles: fluid (\d+)")
KNIT = re.compile(r"knit: (\d+) points")
SPLIT_KEYS = ("exchange", "migration", "refresh", "balance", "knit_ghosts", "reduction", "packing")


def spacing_for(particles):
    """scenes/dambreak.toml's block is 0.2 x 0.2 x 0.4 m: dp for a given fluid count."""
    return (0.016 / particles) ** (1.0 / 3.0)


def pour_scene(out, ratio):
    """scenes/pour.toml made `ratio` times larger in both phases: the fluid spacing over the cube
    root, the square's stitches times the square root each way (49,923 knit points at 1)."""
    text = open(os.path.join(ROOT, "scenes", "pour.toml")).read()
    stitches = int(round(128 * ratio ** 0.5))
    text = re.sub(r"(?m)^spacing = [\d.]+", "spacing = %.8g" % (0.005 / ratio ** (1.0 / 3.0)), text)
    text = re.sub(r"(?m)^(wales|courses) = 128", lambda m: "%s = %d" % (m.group(1), stitches), text)
    path = os.path.join(out, "pour_x%g.toml" % ratio)
    with open(path, "w") as f:
        f.write(text)
    return path


def run(exe, ranks, particles, steps, device, threads, extra, scene="dambreak", out_dir=".",
        profile=False):
    if scene == "pour":
        where = [pour_scene(out_dir, particles)]
    else:
        where = [os.path.join(ROOT, "scenes", "dambreak.toml"),
                 "--set", "fluid.spacing=%.8g" % spacing_for(particles)]
    bind = ["--bind-to", "none"] if threads > 1 else []
    cmd = ["mpiexec", "-n", str(ranks), "--oversubscribe"] + bind + [exe, "run", where[0],
           "--device", device, "--threads", str(threads)] + (["--profile"] if profile else []) + [
           "--set", "output.enabled=false", "--set", "solver.max_steps=%d" % steps] + where[1:] + extra
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    out = subprocess.run(cmd, env=env, capture_output=True, text=True)
    text = out.stdout + out.stderr
    with open(os.path.join(out_dir, "run_%s_%d_np%d_%dsteps.log" % (scene, round(particles), ranks, steps)), "w") as f:
        f.write(" ".join(cmd) + "\n" + text)
    m = DONE.search(text)
    if out.returncode != 0 or not m:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), text[-2000:]))
    steps_run = int(m.group(1))
    sp = SPLIT.search(text)
    split = {k: 1e3 * float(sp.group(i + 2)) / steps_run if sp else 0.0 for i, k in enumerate(SPLIT_KEYS)}
    split["transport"] = sp.group(1) if sp else "-"
    fl, kn = FLUID.search(text), KNIT.search(text)
    counts = (int(fl.group(1)) if fl else 0, int(kn.group(1)) if kn else 0)
    return steps_run, float(m.group(2)), float(m.group(3)), split, counts


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--per-rank", type=float, default=20000, help="weak series: fluid particles a rank")
    ap.add_argument("--total", default="40000", help="strong series: fluid particles in all (comma-separated)")
    ap.add_argument("--series", default="weak,strong")
    ap.add_argument("--profile", action="store_true",
                    help="time every stage (synchronises the device after each: slower, no overlap)")
    ap.add_argument("--scene", default="dambreak", choices=("dambreak", "pour"),
                    help="pour: weak series only, --per-rank is then the size over the paper's")
    ap.add_argument("--steps", default="100",
                    help="steps a run; A,B: run each case for A and for B steps, the step the "
                         "marginal one between")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--threads", type=int, default=1, help="OpenMP threads a rank")
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "cpu", "apps", "knitflow"))
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "out"))
    ap.add_argument("--set", action="append", default=[], help="extra scene override (repeatable)")
    a = ap.parse_args()
    extra = sum((["--set", s] for s in a.set), [])
    ranks = [int(r) for r in a.ranks.split(",")]
    os.makedirs(a.out, exist_ok=True)
    step_counts = [int(x) for x in a.steps.split(",")]
    if len(step_counts) not in (1, 2) or (len(step_counts) == 2 and step_counts[1] <= step_counts[0]):
        sys.exit("--steps: one count, or two increasing (A,B), not %r" % a.steps)
    rows = []
    plan = []
    for series in a.series.split(","):
        if series == "weak":
            plan.append(("weak", None))
        elif a.scene == "dambreak":
            plan += [("strong", float(t)) for t in a.total.split(",")]
    for series, total in plan:
        base = None
        for r in ranks:
            n = a.per_rank * r if series == "weak" else total
            walls = []
            for s in step_counts:
                steps, wall, rate, split, counts = run(a.exe, r, n, s, a.device, a.threads, extra,
                                                       a.scene, a.out, a.profile)
                # The "done" line's wall has 10 ms steps; its rate has four digits.
                walls.append((steps, (counts[0] + counts[1]) / rate * steps if rate > 0 else wall))
            start_ms = 0.0
            if len(walls) == 2:
                (s0, w0), (s1, w1) = walls
                per_step = (w1 - w0) / (s1 - s0)
                start_ms = 1e3 * (w0 - per_step * s0)  # what the start costs over the steady steps
                rate = (counts[0] + counts[1]) / per_step
            else:
                per_step = walls[0][1] / walls[0][0]
            if base is None:
                base = (r, rate)
            # Particle-steps a second a rank against the first run's: weak runs' counts are not
            # exactly proportional to the ranks (whole particles in a block), strong ones are equal.
            eff = (rate / r) / (base[1] / base[0])
            label = series if series == "weak" else "strong %.3gM" % (total / 1e6)
            rows.append({"scene": a.scene, "series": label, "device": a.device, "ranks": r,
                         "fluid": counts[0], "knit": counts[1], "steps": steps,
                         "wall_s": wall, "ms_per_step": 1e3 * per_step, "start_ms": start_ms,
                         "particle_steps_per_s": rate,
                         "efficiency": eff, "transport": split["transport"]})
            rows[-1].update({k + "_ms": split[k] for k in SPLIT_KEYS})
            print("{series:12s} ranks {ranks:3d} fluid {fluid:9d} knit {knit:8d} {ms_per_step:9.3f} ms/step "
                  "{particle_steps_per_s:.3e} particle-steps/s efficiency {efficiency:.3f} | {transport} "
                  "exchanges {exchange_ms:.3f} ms/step (migration {migration_ms:.3f}, refreshes "
                  "{refresh_ms:.3f}, balance {balance_ms:.3f}, knit {knit_ghosts_ms:.3f}, dt all-reduce "
                  "{reduction_ms:.3f}; packing "
                  "{packing_ms:.3f})".format(**rows[-1]), flush=True)
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
        for series in dict.fromkeys(r["series"] for r in rows):
            sel = [r for r in rows if r["series"] == series]
            ax.plot([r["ranks"] for r in sel], [r["efficiency"] for r in sel],
                    "o-" if series == "weak" else "s--", label=series)
        ax.axhline(1.0, color="grey", lw=0.5)
        ax.set(xlabel="ranks", ylabel="parallel efficiency", ylim=(0, 1.1),
               title="knitflow %s, %s, %d thread(s) a rank" % (a.scene, a.device, a.threads))
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
