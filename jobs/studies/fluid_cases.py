"""P7's fluid reference cases: each run's error against a known answer (jobs/studies/accuracy.py).

  hydrostatic  water at rest in a tank: the pressure profile against rho0 g (H - z).
  dambreak     a column released in a tank: the surge front and the residual height against
               Martin & Moyce (1952), and against our own finest run.
  sloshing     water set moving in a closed tank: the first standing wave's period against
               linear theory.
"""
import glob
import math
import os

import h5py
import numpy as np

from study_io import ROOT


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


def paired_fraction(positions, spacing):
    """The fraction of particles with a neighbour nearer than half a spacing: none on a lattice
    or in a settled fluid (a few in a splash), most where the kernel's pairing instability has
    clumped them (the cubic spline past a support of 2 spacings: VALIDATION, P7). Cells half a
    spacing wide: such a neighbour lies in one of the 27 around a particle's."""
    x = np.asarray(positions, dtype=np.float64)
    if len(x) < 2:
        return 0.0
    r = 0.5 * spacing
    cell = np.floor((x - x.min(axis=0)) / r).astype(np.int64) + 1  # a margin of one cell
    dims = cell.max(axis=0) + 2
    key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    order = np.argsort(key, kind="stable")
    ks, xs = key[order], x[order]
    near = np.zeros(len(x), dtype=bool)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                other = ks + (dx * dims[1] + dy) * dims[2] + dz
                lo = np.searchsorted(ks, other, "left")
                count = np.searchsorted(ks, other, "right") - lo
                for j in range(int(count.max())):
                    i = np.nonzero(count > j)[0]
                    k = lo[i] + j
                    d2 = ((xs[i] - xs[k]) ** 2).sum(axis=1)
                    near[i[(k != i) & (d2 < r * r)]] = True
    return float(near.mean())


def last_paired_fraction(run_dir, scene):
    """paired_fraction of the fluid in the run's last snapshot."""
    frames = sorted(glob.glob(os.path.join(run_dir, "frame_*.h5")))
    with h5py.File(frames[-1], "r") as f:
        x = f["fluid/position"][...]
    return round(paired_fraction(x, float(scene["fluid"]["spacing"])), 4)


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
             "height_rms": float(np.sqrt(np.mean(hd ** 2))),
             "paired": last_paired_fraction(run_dir, scene), "_curves": curves}
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
    return error, frames, {"paired": last_paired_fraction(run_dir, scene)}


def centre_of_mass_x(run_dir):
    """The fluid's centre of mass along x at each snapshot: (times, x_cm)."""
    ts, xs = [], []
    for path in sorted(glob.glob(os.path.join(run_dir, "frame_*.h5"))):
        with h5py.File(path, "r") as f:
            x = f["fluid/position"][:, 0].astype(np.float64)
            m = f["fluid/mass"][...].astype(np.float64)
            ts.append(float(f.attrs["time"]))
        xs.append(float((x * m).sum() / m.sum()))
    return np.array(ts), np.array(xs)


def damped_cosine(t, y):
    """The least-squares fit of y = c + e^(-gamma t) (a cos(omega t) + b sin(omega t)): omega and
    gamma by a grid search refined twice (linear least squares for c, a, b at each); returns
    (omega, gamma, amplitude, RMS residual over the amplitude)."""
    def residual(omega, gamma):
        decay = np.exp(-gamma * t)
        A = np.column_stack([np.ones_like(t), decay * np.cos(omega * t), decay * np.sin(omega * t)])
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        return float(np.sum((A @ coef - y) ** 2)), coef

    best = None
    omegas, gammas = np.linspace(1.0, 40.0, 400), np.linspace(0.0, 5.0, 51)
    for _ in range(3):
        for omega in omegas:
            for gamma in gammas:
                r, coef = residual(omega, gamma)
                if best is None or r < best[0]:
                    best = (r, omega, gamma, coef)
        _, w, g, _ = best
        dw, dg = omegas[1] - omegas[0], gammas[1] - gammas[0]
        omegas = np.linspace(w - 2 * dw, w + 2 * dw, 41)
        gammas = np.linspace(max(g - 2 * dg, 0.0), g + 2 * dg, 41)
    r, omega, gamma, coef = best
    amplitude = math.hypot(coef[1], coef[2])
    return omega, gamma, amplitude, math.sqrt(r / len(t)) / max(amplitude, 1e-30)


def sloshing_error(run_dir, scene):
    """The first standing wave's period against linear theory (omega^2 = g k tanh(k H), k = pi /
    L, H the fill depth the water's volume gives): a damped cosine fitted to the centre of mass
    along x over the first 2 s. A uniform start excites the odd modes n = 1, 3, 5, ... (the
    surface's potential U (x - L/2) in cos(n pi x / L): 1/n^2 each), which move the centre of
    mass as omega_n / n^4: the third 1.81x as fast here (deep water: about sqrt(3)) and 2.2% of
    the first; fitted alone it lengthens the period by at most 0.1% (0.5% at 10%)."""
    lo, hi = scene["domain"]["min"], scene["domain"]["max"]
    L, W = hi[0] - lo[0], hi[1] - lo[1]
    g = -scene.get("simulation", {}).get("gravity", [0, 0, -9.81])[2]
    block = scene["fluid"]["block"][0]
    depth = block["max"][2] - block["min"][2]
    k = math.pi / L
    omega0 = math.sqrt(g * k * math.tanh(k * depth))
    t, x = centre_of_mass_x(run_dir)
    keep = t <= 2.0 + 1e-9
    omega, gamma, amplitude, misfit = damped_cosine(t[keep], x[keep])
    error = abs(omega0 / omega - 1.0)  # the period's relative error
    return error, int(keep.sum()), {
        "period_s": round(2 * math.pi / omega, 5), "period_linear_s": round(2 * math.pi / omega0, 5),
        "damping_per_s": round(gamma, 4), "amplitude_m": round(amplitude, 6),
        "fit_misfit": round(misfit, 4), "depth_m": round(depth, 4), "width_m": W,
        "paired": last_paired_fraction(run_dir, scene)}
