#!/usr/bin/python3
"""What accuracy costs in time (P7): a reference case run at several settings of one axis, the
rest as its scene has them; each run's error against the known answer beside its wall time.

    jobs/studies/accuracy.py [--full] [--exe KNITFLOW] [--device cpu|cuda] [--out DIR]
                             [--case hydrostatic|dambreak|all] [--axis AXIS|all]

Writes DIR/CASE_AXIS.csv (a row a run: the axis's value, the error, wall seconds, steps,
particles, peak memory, device, commit, and the case's own measures), DIR/CASE_AXIS.png (error
against wall time, and against the axis), and prints the observed order of convergence (the
least-squares slope of log error over log spacing) for the spacing axis. --axis all runs every
axis of the case (a setting met twice runs once) and adds DIR/CASE_pareto.png: every run's error
against its wall time, coloured by axis, with the Pareto front (the runs no other beats on both).
--case all --axis all: every study. Without --full, the small version: minutes on two CPU cores
(CI); --full, the resolutions a GPU takes.

Axes (one at a time, the rest as the case's scene has them): spacing; cfl; kernel (spiky, cubic,
wendland); support (h / dp); sound_speed [m/s]; density (summation, continuity); precision
(float, double); neighbour_list (off, on, verlet); quality ([solver] quality's presets).

Cases:
  hydrostatic  scenes/hydrostatic.toml, water at rest in a tank. Error: the RMS over slices one
               spacing thick of (mean pressure - rho0 g (H - mean z)) over rho0 g H, H the fill
               height the fluid's volume gives, averaged over the snapshots of the last 0.2 s
               (after the settling's damping ends at 0.6 s).
  dambreak     scenes/dambreak.toml to t = 0.3 s (the front reaches the far wall at T ~ 3.2), a
               column a = 0.2 m wide. Error: the RMS of the relative deviations from Martin &
               Moyce (1952, tests/data) of the surge front Z(T) at T + dT, dT >= 0 the release
               delay fitted by least squares (their gate delays the front; an instant release
               leads by about 0.25 in T: tests/test_dambreak.cpp), and of the residual height
               H(tau) at the back wall, at the snapshots within the data's range; the front and
               the height each the median over rows one spacing wide across the tank.
"""
import argparse
import csv
import glob
import json
import math
import os
import subprocess
import sys
import time
import tomllib

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Each axis's settings: the small study's (CPU, CI) and the full one's; the other axes run at the
# small or full base spacing.
COMMON_AXES = {
    "cfl": [0.4, 0.3, 0.2, 0.1],
    "kernel": ["spiky", "cubic", "wendland"],
    "support": [1.5, 2.0, 2.5],
    "density": ["summation", "continuity"],
    "precision": ["float", "double"],
    "neighbour_list": ["off", "on", "verlet"],
    # [solver] quality's presets, on the base spacing (preview twice it, reference half).
    "quality": ["preview", "production", "reference"],
}
AXES = {
    "hydrostatic": {
        "spacing": {"small": [0.02, 0.015, 0.01, 0.0075], "full": [0.02, 0.01, 0.005, 0.0025]},
        "base": {"small": 0.015, "full": 0.005},
        "sound_speed": [10.0, 20.0, 40.0],
    },
    "dambreak": {
        # A whole number of particles across the column (small 8, 10, 16, 20; full 10 to 80; a =
        # 0.2 m).
        "spacing": {"small": [0.025, 0.02, 0.0125, 0.01], "full": [0.02, 0.01, 0.005, 0.0025]},
        "base": {"small": 0.0125, "full": 0.005},
        "sound_speed": [15.0, 30.0, 60.0],
    },
}


def axis_values(case, axis, full):
    spec = AXES[case]
    if axis == "spacing":
        return spec["spacing"]["full" if full else "small"]
    if axis == "sound_speed":
        return spec["sound_speed"]
    if axis in COMMON_AXES:
        return COMMON_AXES[axis]
    known = ["spacing", "sound_speed"] + list(COMMON_AXES)
    raise SystemExit(f"case '{case}' has no axis '{axis}' (known: {', '.join(known)})")


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


def read_curve(name):
    """A digitised curve of tests/data: (x, y) rows after '#' comments and a header."""
    rows = []
    with open(os.path.join(ROOT, "tests", "data", name)) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#") or not line[0].isdigit() and line[0] != ".":
                continue
            x, y = line.split(",")[:2]
            rows.append((float(x), float(y)))
    return np.array(rows)


def dambreak_error(run_dir, scene):
    """The surge front and residual height against Martin & Moyce, RMS relative deviation."""
    block = scene["fluid"]["block"][0]
    a = block["max"][0] - block["min"][0]
    g = -scene.get("simulation", {}).get("gravity", [0, 0, -9.81])[2]
    dp = float(scene["fluid"]["spacing"])
    x0 = block["min"][0]
    front_data, height_data = read_curve("martin_moyce_1952.csv"), read_curve(
        "martin_moyce_1952_height.csv")
    Ts, Zs, taus, Hs = [], [], [], []
    for path in sorted(glob.glob(os.path.join(run_dir, "frame_*.h5"))):
        with h5py.File(path, "r") as f:
            t = float(f.attrs["time"])
            x = f["fluid/position"][...].astype(np.float64)
        if t <= 0:
            continue
        # Across the tank's width, in rows one spacing wide: the front, each row's farthest x
        # near the floor; the residual height, each row's highest z within 2 dp of the back
        # wall; the median over the rows, plus half a spacing (a droplet ahead or a film held
        # on the wall by its no-slip is a row or two, not the median).
        rows = np.floor((x[:, 1] - scene["domain"]["min"][1]) / dp).astype(int)
        near_floor = x[:, 2] < 0.5 * a
        at_wall = x[:, 0] - x0 < 2 * dp
        front = [x[near_floor & (rows == r), 0].max() for r in np.unique(rows[near_floor])]
        height = [x[at_wall & (rows == r), 2].max() for r in np.unique(rows[at_wall])]
        if front:
            Ts.append(t * math.sqrt(2 * g / a))
            Zs.append((np.median(front) - x0 + 0.5 * dp) / a)
        if height:
            taus.append(t * math.sqrt(g / a))
            Hs.append((np.median(height) + 0.5 * dp) / (2 * a))
    Ts, Zs, taus, Hs = map(np.asarray, (Ts, Zs, taus, Hs))
    curves = {"front": (Ts.copy(), Zs.copy()), "height": (taus.copy(), Hs.copy())}
    # The front until it nears the far wall (4a from the back: Z < 3.8) and within the data.
    tank = (scene["domain"]["max"][0] - x0) / a
    keep = (Zs < tank - 0.2) & (Ts <= front_data[-1, 0])
    Ts, Zs = Ts[keep], Zs[keep]

    def front_dev(shift):
        inside = (Ts + shift >= front_data[0, 0]) & (Ts + shift <= front_data[-1, 0])
        ref = np.interp(Ts[inside] + shift, front_data[:, 0], front_data[:, 1])
        return (Zs[inside] - ref) / ref

    shifts = np.arange(0.0, 0.5 + 1e-9, 0.005)
    best = min(shifts, key=lambda d: float(np.sum(front_dev(d) ** 2)) / max(len(front_dev(d)), 1))
    fd = front_dev(best)
    inside = (taus >= height_data[0, 0]) & (taus <= height_data[-1, 0])
    href = np.interp(taus[inside], height_data[:, 0], height_data[:, 1])
    hd = (Hs[inside] - href) / href
    if len(fd) < 5 or len(hd) < 5:
        raise SystemExit(f"{run_dir}: {len(fd)} front and {len(hd)} height points to compare")
    error = float(np.sqrt(np.mean(np.concatenate([fd, hd]) ** 2)))
    extra = {"release_delay": round(float(best), 3),
             "front_rms": float(np.sqrt(np.mean(fd ** 2))),
             "height_rms": float(np.sqrt(np.mean(hd ** 2))), "_curves": curves}
    return error, len(fd) + len(hd), extra


def self_error(curves, reference):
    """The RMS relative difference of a run's curves (front, height) from a finer run's, at the
    snapshots both hold (the same times: a fixed output interval), the front until it nears the
    far wall in the finer run (Z < 3.8)."""
    dev = []
    for name, (t, y) in curves.items():
        rt, ry = reference[name]
        n = min(len(t), len(rt))
        if not np.allclose(t[:n], rt[:n], rtol=1e-6):
            raise SystemExit(f"the runs' {name} curves are sampled at different times")
        keep = ry[:n] < 3.8 if name == "front" else np.ones(n, bool)
        dev.append((y[:n][keep] - ry[:n][keep]) / ry[:n][keep])
    return float(np.sqrt(np.mean(np.concatenate(dev) ** 2)))


def hydrostatic_case_error(run_dir, scene):
    error, frames = hydrostatic_error(run_dir, scene)
    return error, frames, {}


# A case: its scene, its error, and the settings every run of it takes.
CASES = {
    "hydrostatic": ("scenes/hydrostatic.toml", hydrostatic_case_error, []),
    "dambreak": ("scenes/dambreak.toml", dambreak_error,
                 ["simulation.end_time=0.3", "output.interval=0.01"]),
}


def setting(axis, value):
    """The --set overrides for one value of an axis."""
    keys = {"spacing": "fluid.spacing", "cfl": "solver.cfl", "kernel": "solver.kernel",
            "support": "fluid.support", "sound_speed": "fluid.speed_of_sound",
            "density": "solver.density", "precision": "simulation.precision",
            "neighbour_list": "solver.neighbour_list", "quality": "solver.quality"}
    if axis not in keys:
        raise SystemExit(f"unknown axis '{axis}' (known: {', '.join(keys)})")
    return [f"{keys[axis]}={json.dumps(value)}"]


# [solver] quality's spacing scales (src/domain/QualityPresets.cpp): the errors read the spacing.
QUALITY_SPACING = {"preview": 2.0, "production": 1.0, "reference": 0.5}


def applied(scene, overrides):
    """The scene's table with KEY=VALUE overrides (TOML values) set, as `run --set` does, and a
    quality preset's spacing scale."""
    scene = json.loads(json.dumps(scene))
    for o in overrides:
        key, value = o.split("=", 1)
        *path, last = key.split(".")
        t = scene
        for k in path:
            t = t.setdefault(k, {})
        t[last] = tomllib.loads(f"v = {value}")["v"]
    quality = scene.get("solver", {}).get("quality")
    if quality:
        scene["fluid"]["spacing"] *= QUALITY_SPACING[quality]
    return scene


def commit():
    """The tree's commit (KF_COMMIT where the runs' checkout is a copy without its history)."""
    if os.environ.get("KF_COMMIT"):
        return os.environ["KF_COMMIT"]
    done = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True)
    return done.stdout.strip() or "unknown"


def run(exe, scene_path, overrides, out, device):
    """Runs knitflow; its wall seconds and peak resident memory [MB]."""
    cmd = [exe, "run", scene_path, "--device", device, "--quiet", "--output", out]
    for o in overrides:
        cmd += ["--set", o]
    t0 = time.monotonic()
    child = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    log = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.monotonic() - t0
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {code}\n{log}")
    return wall, usage.ru_maxrss / 1024.0


def steps(run_dir):
    last = sorted(glob.glob(os.path.join(run_dir, "frame_*.h5")))[-1]
    with h5py.File(last, "r") as f:
        return int(f.attrs["step"])


def particles(run_dir):
    first = sorted(glob.glob(os.path.join(run_dir, "frame_*.h5")))[0]
    with h5py.File(first, "r") as f:
        return int(f["fluid/position"].shape[0])


def observed_order(values, errors):
    """The least-squares slope of log error over log value."""
    x, y = np.log(np.asarray(values)), np.log(np.asarray(errors))
    return float(np.polyfit(x, y, 1)[0])


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot(rows, case, axis, path):
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    wall = [r["wall_s"] for r in rows]
    err = [r["error"] for r in rows]
    a.loglog(wall, err, "o-")
    for r in rows:
        a.annotate(f"{r['value']}", (r["wall_s"], r["error"]), fontsize=8)
    a.set_xlabel("wall time [s]")
    a.set_ylabel("error")
    a.set_title(f"{case}: error against time ({axis})")
    numeric = all(isinstance(r["value"], (int, float)) for r in rows)
    if numeric:
        b.loglog([r["value"] for r in rows], err, "o-")
    else:
        b.bar([str(r["value"]) for r in rows], err)
        b.set_yscale("log")
    b.set_xlabel(axis)
    b.set_ylabel("error")
    b.set_title(f"{case}: error against {axis}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def pareto_front(rows):
    """The runs no other run beats on both wall time and error, by wall time."""
    front = [r for r in rows if not any(
        o["wall_s"] <= r["wall_s"] and o["error"] <= r["error"]
        and (o["wall_s"] < r["wall_s"] or o["error"] < r["error"]) for o in rows)]
    return sorted(front, key=lambda r: r["wall_s"])


def plot_pareto(rows, case, path):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for axis in dict.fromkeys(r["axis"] for r in rows):
        mine = [r for r in rows if r["axis"] == axis]
        ax.loglog([r["wall_s"] for r in mine], [r["error"] for r in mine], "o", label=axis)
        for r in mine:
            ax.annotate(f"{r['value']}", (r["wall_s"], r["error"]), fontsize=7)
    front = pareto_front(rows)
    ax.loglog([r["wall_s"] for r in front], [r["error"] for r in front], "k--", lw=1,
              label="Pareto front")
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("error")
    ax.set_title(f"{case}: every run's error against its time")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_csv(rows, path):
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "cpu", "apps", "knitflow"))
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "studies"))
    ap.add_argument("--case", default="hydrostatic", choices=sorted(CASES) + ["all"])
    ap.add_argument("--axis", default="spacing")
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--plot", metavar="CSV", nargs="+",
                    help="no runs: the plots of earlier runs' CSVs (a case's rows) into --out")
    a = ap.parse_args()
    if a.plot:
        replot(a.plot, a.out)
        return
    for case in sorted(CASES) if a.case == "all" else [a.case]:
        study(a, case)


def replot(paths, out):
    """The plots of CSVs an earlier study wrote (one case; an axis's rows or all of them)."""
    rows = []
    for path in paths:
        with open(path) as f:
            for r in csv.DictReader(f):
                for k, v in r.items():
                    try:
                        r[k] = float(v)
                    except ValueError:
                        pass
                rows.append(r)
    cases = {r["case"] for r in rows}
    if len(cases) != 1:
        raise SystemExit(f"{len(cases)} cases in {', '.join(paths)}: plot one at a time")
    case = cases.pop()
    os.makedirs(out, exist_ok=True)
    for axis in dict.fromkeys(r["axis"] for r in rows):
        plot([r for r in rows if r["axis"] == axis], case, axis,
             os.path.join(out, f"{case}_{axis}.png"))
    if len({r["axis"] for r in rows}) > 1:
        plot_pareto(rows, case, os.path.join(out, f"{case}_pareto.png"))
    print(f"plotted {len(rows)} rows of {case} into {out}")


def study(a, case):
    """One case's sweeps (a's axis or all of them)."""
    a = argparse.Namespace(**{**vars(a), "case": case})
    scene_rel, error_of, fixed = CASES[a.case]
    scene_path = os.path.join(ROOT, scene_rel)
    with open(scene_path, "rb") as f:
        base_scene = tomllib.load(f)
    axes = ["spacing", "sound_speed"] + list(COMMON_AXES) if a.axis == "all" else [a.axis]
    for axis in axes:
        axis_values(a.case, axis, a.full)  # refuses an unknown axis before any run
    os.makedirs(a.out, exist_ok=True)
    version = commit()
    done = {}  # a setting met twice (the base in every axis) runs once
    every = []
    for axis in axes:
        rows = []
        base = [] if axis == "spacing" else setting("spacing", AXES[a.case]["base"][
            "full" if a.full else "small"])
        for v in axis_values(a.case, axis, a.full):
            overrides = fixed + base + setting(axis, v)
            scene = applied(base_scene, overrides)
            key = json.dumps(scene, sort_keys=True)
            if key not in done:
                out = os.path.join(a.out, f"{a.case}_{axis}_{v}")
                wall, memory = run(a.exe, scene_path, overrides, out, a.device)
                error, frames, extra = error_of(out, scene)
                done[key] = {"particles": particles(out), "steps": steps(out),
                             "wall_s": round(wall, 3), "error": error, "frames": frames,
                             "memory_mb": round(memory, 1), **extra}
            r = {"case": a.case, "axis": axis, "value": v, **done[key], "device": a.device,
                 "commit": version}
            rows.append(r)
            print(f"{a.case} {axis} = {v}: {r['particles']} particles, {r['steps']} steps, "
                  f"{r['wall_s']:.1f} s, error {r['error']:.4g} ({r['frames']} points)", flush=True)
        if axis == "spacing" and "_curves" in rows[-1]:
            # Against our own finest run: how far each coarser one is from where refinement
            # goes (the experiment holds a floor: its scatter, the gate's release).
            for r in rows[:-1]:
                r["self_error"] = self_error(r["_curves"], rows[-1]["_curves"])
            order = observed_order([r["value"] for r in rows[:-1]],
                                   [r["self_error"] for r in rows[:-1]])
            print(f"{a.case}: against the finest run, errors "
                  + ", ".join(f"{r['self_error']:.4g}" for r in rows[:-1])
                  + f"; observed order {order:.2f}")
        for r in rows:
            r.pop("_curves", None)
        write_csv(rows, os.path.join(a.out, f"{a.case}_{axis}.csv"))
        png = os.path.join(a.out, f"{a.case}_{axis}.png")
        plot(rows, a.case, axis, png)
        if axis == "spacing":
            order = observed_order([r["value"] for r in rows], [r["error"] for r in rows])
            print(f"{a.case}: observed order {order:.2f} over spacing {rows[0]['value']:g}.."
                  f"{rows[-1]['value']:g}")
        print(f"wrote {os.path.join(a.out, f'{a.case}_{axis}.csv')} and {png}")
        every += rows
    if a.axis == "all":
        write_csv(every, os.path.join(a.out, f"{a.case}_all.csv"))
        plot_pareto(every, a.case, os.path.join(a.out, f"{a.case}_pareto.png"))
        front = pareto_front(every)
        print(f"{a.case}: Pareto front " + ", ".join(
            f"{r['axis']}={r['value']} ({r['wall_s']:.1f} s, {r['error']:.3g})" for r in front))


if __name__ == "__main__":
    main()
