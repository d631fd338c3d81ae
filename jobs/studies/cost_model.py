#!/usr/bin/python3
"""The cost model of a run (P7): fitted to the accuracy studies' timings, checked against them.

    jobs/studies/cost_model.py --exe KNITFLOW CSV [CSV ...] [--out FILE.toml]

A run's wall time on a device is predicted as (src/domain/CostModel.hpp)

    T = start + S f (step + (support / 2)^3 fluid N_fluid + boundary N_boundary)

S the run's steps, N the particles, the support and the settings that carry a factor f as
`knitflow plan` gives them (its "model" line: S = end_time over the CFL step at the fluid's fall
speed from its top, none where the scene damps its motion toward rest): f the product of a factor
a setting (the continuity density, the neighbour lists "on", "verlet" in a settling scene and in
a flowing one, double precision) on a whole step (on a GPU a small step is mostly its kernels'
launches, which a setting changes with its passes). start, step, fluid and boundary are fitted by
least squares on relative error over the runs without such settings; each setting's factor is
then the geometric mean of what its runs ask for. Every study run's prediction is printed against
its measured time; --out writes the device's table into the model file (src/domain/CostModel.toml,
which the app compiles in), keeping the other devices'.
"""
import argparse
import csv
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import accuracy  # noqa: E402  (the studies' cases and settings)

def overrides_of(row, full):
    """The --set overrides the study gave this row's run."""
    case, axis, value = row["case"], row["axis"], row["value"]
    _, _, fixed = accuracy.CASES[case]
    base = [] if axis == "spacing" else accuracy.setting(
        "spacing", accuracy.AXES[case]["base"]["full" if full else "small"])
    try:
        value = float(value)
    except ValueError:
        pass
    return fixed + base + accuracy.setting(axis, value)


def plan_of(exe, case, overrides):
    """The model's inputs as `knitflow plan` gives them: its "model" line (particles, support,
    the run's steps, the settings that carry a factor)."""
    cmd = [exe, "plan", os.path.join(accuracy.ROOT, accuracy.CASES[case][0])]
    for o in overrides:
        cmd += ["--set", o]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    m = re.search(r"model\s+fluid (\d+), boundary (\d+), knit (\d+), support (\S+), steps (\d+), "
                  r"settings (\S+)", text)
    if not m:
        raise SystemExit(f"{' '.join(cmd)}: no model line in the plan")
    return {"fluid": int(m.group(1)), "boundary": int(m.group(2)), "knit": int(m.group(3)),
            "support": float(m.group(4)), "steps": float(m.group(5)),
            "settings": [] if m.group(6) == "none" else m.group(6).split(",")}


def step_factor(row, factors):
    f = 1.0
    for name in row["settings"]:
        f *= factors.get(name, 1.0)
    return f


def step_cost(c, row):
    return c[1] + (row["support"] / 2.0) ** 3 * c[2] * row["Nf"] + c[3] * row["Nb"]


def predict(c, row, factors):
    return c[0] + row["S"] * step_factor(row, factors) * step_cost(c, row)


def fit(rows):
    base = [r for r in rows if not r["settings"]]
    A = np.array([[1.0, r["S"], r["S"] * r["Nf"], r["S"] * r["Nb"]] for r in base])
    w = np.array([1.0 / r["wall"] for r in base])
    y = np.array([r["wall"] for r in base])
    c, *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
    c = np.maximum(c, 0.0)
    asks = {}
    for r in rows:
        if len(r["settings"]) == 1:  # a setting's own runs ask for its factor
            step = r["S"] * step_cost(c, r)
            asks.setdefault(r["settings"][0], []).append(max(r["wall"] - c[0], 0.05 * step) / step)
    factors = {k: float(np.exp(np.mean(np.log(v)))) for k, v in asks.items()}
    return c, factors


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("csv", nargs="+")
    ap.add_argument("--exe", default=os.path.join(accuracy.ROOT, "build", "cpu", "apps", "knitflow"))
    ap.add_argument("--full", action="store_true", help="the CSVs are of --full studies")
    ap.add_argument("--device", default=None, help="the device's name in the model")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    rows = []
    for path in a.csv:
        with open(path) as f:
            for r in csv.DictReader(f):
                p = plan_of(a.exe, r["case"], overrides_of(r, a.full))
                r.update(S=p["steps"], settings=p["settings"], support=p["support"],
                         steps=int(float(r["steps"])), Nf=p["fluid"], Nb=p["boundary"],
                         wall=float(r["wall_s"]))
                rows.append(r)
    c, factors = fit(rows)
    worst = 0.0
    print(f"{'case':12} {'axis':15} {'value':>10} {'fluid':>9} {'boundary':>9} {'steps':>7} "
          f"{'predicted':>7} {'measured':>9} {'predicted':>10} {'off':>6}")
    for r in rows:
        t = predict(c, r, factors)
        off = t / r["wall"] - 1
        worst = max(worst, abs(off))
        print(f"{r['case']:12} {r['axis']:15} {str(r['value']):>10} {r['Nf']:9d} {r['Nb']:9d} "
              f"{r['steps']:7d} {r['S']:7.0f} {r['wall']:9.2f} {t:10.2f} {100 * off:+5.0f}%")
    device = a.device or rows[0].get("device", "device")
    print(f"{device}: t_start {c[0]:.3g} s, a step {c[1]:.3g} s + {c[2]:.3g} s a fluid particle "
          f"+ {c[3]:.3g} s a boundary particle; factors "
          + ", ".join(f"{k} x{f:.2f}" for k, f in factors.items())
          + f"; worst prediction {100 * worst:.0f}% off over {len(rows)} runs")
    if a.out:
        write_model(a.out, device, c, factors, worst, a.csv)


def write_model(path, device, c, factors, worst, sources):
    """The device's table into the model file, the other devices' kept."""
    lines = open(path).read().splitlines() if os.path.exists(path) else []
    kept, skip = [], False
    for line in lines:
        if line.startswith("["):
            skip = line.strip() == f"[{device}]"
        if not skip:
            kept.append(line)
    while kept and not kept[-1].strip():
        kept.pop()
    table = [f"[{device}]",
             f"# fitted by jobs/studies/cost_model.py to {', '.join(os.path.basename(p) for p in sources)}",
             f"start_s = {c[0]:.6g}", f"step_s = {c[1]:.6g}", f"fluid_s = {c[2]:.6g}",
             f"boundary_s = {c[3]:.6g}"]
    table += [f"{k} = {f:.4g}" for k, f in factors.items()]
    table.append(f"worst_off = {worst:.3f}")
    with open(path, "w") as f:
        f.write("\n".join(kept + ([""] if kept else []) + table) + "\n")


if __name__ == "__main__":
    main()
