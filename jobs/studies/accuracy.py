#!/usr/bin/python3
"""What accuracy costs in time (P7): a reference case run at several settings of one axis, the
rest as its scene has them; each run's error against the known answer beside its wall time.

    jobs/studies/accuracy.py [--full] [--exe KNITFLOW] [--device cpu|cuda] [--out DIR]
                             [--case hydrostatic] [--axis spacing]

Writes DIR/CASE_AXIS.csv (a row a run: the axis's value, particles, wall seconds, the error),
DIR/CASE_AXIS.png (error against wall time, and against the axis), and prints the observed
order of convergence (the least-squares slope of log error over log spacing) for the spacing
axis. Without --full, the small version: minutes on two CPU cores (CI); --full, the resolutions
a GPU takes.

Cases:
  hydrostatic  scenes/hydrostatic.toml, water at rest in a tank. Error: the RMS over slices one
               spacing thick of (mean pressure - rho0 g (H - mean z)) over rho0 g H, H the fill
               height the fluid's volume gives, averaged over the snapshots of the last 0.2 s
               (after the settling's damping ends at 0.6 s).
"""
import argparse
import csv
import glob
import math
import os
import subprocess
import sys
import time
import tomllib

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Each axis's settings: the small study's (CPU, CI) and the full one's.
AXES = {
    "hydrostatic": {
        "spacing": {"small": [0.02, 0.015, 0.01, 0.0075], "full": [0.02, 0.01, 0.005, 0.0025]},
    },
}


def hydrostatic_error(run_dir, scene):
    """The tank's pressure profile error (of rho0 g H) over the last 0.2 s of snapshots."""
    fluid = scene["fluid"]
    rho0 = fluid.get("rest_density", 1000.0)
    g = -scene.get("simulation", {}).get("gravity", [0, 0, -9.81])[2]
    lo, hi = scene["domain"]["min"], scene["domain"]["max"]
    area = (hi[0] - lo[0]) * (hi[1] - lo[1])
    frames = sorted(glob.glob(os.path.join(run_dir, "frame_*.h5")))
    if not frames:
        raise SystemExit(f"{run_dir}: no snapshots")
    with h5py.File(frames[-1], "r") as f:
        end = float(f.attrs["time"])
    errors = []
    for path in frames:
        with h5py.File(path, "r") as f:
            if float(f.attrs["time"]) < end - 0.2 - 1e-9:
                continue
            z = f["fluid/position"][:, 2].astype(np.float64)
            p = f["fluid/pressure"][...].astype(np.float64)
            m = f["fluid/mass"][...].astype(np.float64)
        depth = m.sum() / (rho0 * area)  # the fill height the fluid's volume gives
        dp = float(fluid["spacing"])
        edges = np.arange(lo[2], lo[2] + depth + 0.5 * dp, dp)
        which = np.digitize(z, edges) - 1
        sq = []
        for k in range(len(edges) - 1):
            inside = which == k
            if inside.sum() == 0:
                continue
            expected = rho0 * g * (depth - z[inside].mean())
            sq.append((p[inside].mean() - expected) ** 2)
        errors.append(math.sqrt(np.mean(sq)) / (rho0 * g * depth))
    return float(np.mean(errors)), len(errors)


CASES = {"hydrostatic": ("scenes/hydrostatic.toml", hydrostatic_error)}


def setting(axis, value):
    """The --set overrides for one value of an axis."""
    if axis == "spacing":
        return [f"fluid.spacing={value}"]
    raise SystemExit(f"unknown axis '{axis}' (known: spacing)")


def run(exe, scene_path, overrides, out, device):
    cmd = [exe, "run", scene_path, "--device", device, "--quiet", "--output", out]
    for o in overrides:
        cmd += ["--set", o]
    t0 = time.monotonic()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stdout}{done.stderr}")
    return wall


def particles(run_dir):
    first = sorted(glob.glob(os.path.join(run_dir, "frame_*.h5")))[0]
    with h5py.File(first, "r") as f:
        return int(f["fluid/position"].shape[0])


def observed_order(values, errors):
    """The least-squares slope of log error over log value."""
    x, y = np.log(np.asarray(values)), np.log(np.asarray(errors))
    return float(np.polyfit(x, y, 1)[0])


def plot(rows, case, axis, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    wall = [r["wall_s"] for r in rows]
    err = [r["error"] for r in rows]
    a.loglog(wall, err, "o-")
    for r in rows:
        a.annotate(f"{r['value']:g}", (r["wall_s"], r["error"]), fontsize=8)
    a.set_xlabel("wall time [s]")
    a.set_ylabel("error")
    a.set_title(f"{case}: error against time ({axis})")
    b.loglog([r["value"] for r in rows], err, "o-")
    b.set_xlabel(axis)
    b.set_ylabel("error")
    b.set_title(f"{case}: error against {axis}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "cpu", "apps", "knitflow"))
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "studies"))
    ap.add_argument("--case", default="hydrostatic", choices=sorted(CASES))
    ap.add_argument("--axis", default="spacing")
    ap.add_argument("--full", action="store_true")
    a = ap.parse_args()
    scene_rel, error_of = CASES[a.case]
    scene_path = os.path.join(ROOT, scene_rel)
    if a.axis not in AXES[a.case]:
        raise SystemExit(f"case '{a.case}' has no axis '{a.axis}' (known: {', '.join(AXES[a.case])})")
    values = AXES[a.case][a.axis]["full" if a.full else "small"]
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for v in values:
        overrides = setting(a.axis, v)
        with open(scene_path, "rb") as f:
            scene = tomllib.load(f)
        if a.axis == "spacing":
            scene["fluid"]["spacing"] = v
        out = os.path.join(a.out, f"{a.case}_{a.axis}_{v:g}")
        wall = run(a.exe, scene_path, overrides, out, a.device)
        error, frames = error_of(out, scene)
        rows.append({"case": a.case, "axis": a.axis, "value": v, "particles": particles(out),
                     "wall_s": round(wall, 3), "error": error, "frames": frames})
        print(f"{a.case} {a.axis} = {v:g}: {rows[-1]['particles']} particles, {wall:.1f} s, "
              f"error {error:.4g} ({frames} snapshots)", flush=True)
    csv_path = os.path.join(a.out, f"{a.case}_{a.axis}.csv")
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    png = os.path.join(a.out, f"{a.case}_{a.axis}.png")
    plot(rows, a.case, a.axis, png)
    if a.axis == "spacing":
        order = observed_order([r["value"] for r in rows], [r["error"] for r in rows])
        print(f"{a.case}: observed order {order:.2f} over spacing {values[0]:g}..{values[-1]:g}")
    print(f"wrote {csv_path} and {png}")


if __name__ == "__main__":
    main()
