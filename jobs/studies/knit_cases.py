"""P7's knit reference cases: each run's error against a known answer (jobs/studies/accuracy.py).

  catenary  a strip hung from both ends, settled: its centre line against the catenary of the
            same span and arc length (analytic).
  wicking   a strip dipped into a pool: the wetted height against Lucas-Washburn with gravity (a
            sharp front, the suction P_c(0) behind it), and against the 1-D Darcy flow of the
            same law with a saturated foot.
  drape     a square dropped over a ball: its points against a converged run of our own.
  pour      water poured onto it: the absorbed mass against time and the knit's points against a
            converged run of our own.

An error function takes a run's directory and its scene (the table the run read) and returns
(error, points compared, extra columns); "_ref" in the extras is what a finer run is compared by
(the run's directory), "_compare" the function that compares a run with it.
"""
import math

import h5py
import numpy as np

from study_io import frames, frame_time


def piece(scene):
    return scene["knit"]["piece"][0]


def catenary_error(run_dir, scene):
    """The settled strip's middle-layer centre line against y = a cosh(x / a), a from its span
    and arc length (which include its stretch): the largest deviation over the span."""
    with h5py.File(frames(run_dir)[-1], "r") as f:
        x = f["knit/position"][...].astype(np.float64)
        rest = f["knit/rest_position"][...].astype(np.float64)
        layer = f["knit/layer"][...]
    mid = layer == 1
    # The centre line: the middle layer's points at each rest x, averaged across the width.
    u = np.round(rest[mid, 0], 9)
    keys = np.unique(u)
    c = np.array([x[mid][u == k].mean(axis=0) for k in keys])
    arc = float(np.sum(np.linalg.norm(np.diff(c, axis=0), axis=1)))
    span = float(c[-1, 0] - c[0, 0])
    xm = 0.5 * (c[-1, 0] + c[0, 0])
    lo, hi = 1e-4, 1e3  # arc = 2 a sinh(S / 2a) falls as a grows
    for _ in range(200):
        a = 0.5 * (lo + hi)
        if 2 * a * math.sinh(span / (2 * a)) > arc:
            lo = a
        else:
            hi = a
    z_end = 0.5 * (c[0, 2] + c[-1, 2])
    ref = z_end + a * (np.cosh((c[:, 0] - xm) / a) - math.cosh(span / (2 * a)))
    worst = float(np.max(np.abs(c[:, 2] - ref)))
    return worst / span, len(c), {"sag_m": round(float(z_end - c[len(c) // 2, 2]), 5),
                                  "catenary_a_m": round(a, 5)}


# Leverett's J (src/kernels/coupling/Coupling_K.hpp) and the model's relative permeability.
def leverett_j(s):
    u = 1.0 - s
    return u * (1.417 + u * (-2.120 + u * 1.263))


def wetted_height(path, scene, pool):
    """The absorbed fluid above the pool's surface over the strip's capacity a unit height
    (test_wicking's measure: a splashed point is no front)."""
    k, cap = scene["knit"], scene["capillary"]
    rho0 = scene["fluid"].get("rest_density", 1000.0)
    per_dry = cap["porosity"] * rho0 * k["thickness"] / k["mass_per_area"]
    with h5py.File(path, "r") as f:
        z = f["knit/position"][:, 2].astype(np.float64)
        a = f["knit/fluid_mass"][...].astype(np.float64)
        m = f["knit/mass"][...].astype(np.float64)
        t = float(f.attrs["time"])
    capacity = per_dry * (m - a).sum()
    return t, a[z > pool].sum() / (capacity / piece(scene)["height"])


def darcy_1d(h0, t0, times, scene, pool, dz=2.5e-4):
    """The wetted height at `times` of the 1-D Darcy flow up a strip whose foot stands in the
    pool (saturated there), wet to h0 at t0 (a sharp front): phi ds/dt = d/dz[kappa/mu k_r(s)
    d/dz(P_c(s) ... )] with the model's P_c = sigma J(s) / sqrt(kappa / phi) (s clamped at 1.5),
    k_r = s^3 of the upwind cell and gravity: explicit finite volumes, dz well below the knit's
    spacing (the solution changes by under 1% from dz = 5e-4 to 2.5e-4)."""
    cap, fl = scene["capillary"], scene["fluid"]
    kappa, phi, sigma = cap["permeability"], cap["porosity"], cap["sigma"]
    mu, rho0 = max(fl["viscosity"], 1e-6), fl.get("rest_density", 1000.0)
    g = -scene.get("simulation", {}).get("gravity", [0, 0, -9.81])[2]
    scale = sigma / math.sqrt(kappa / phi)
    n = int(math.ceil((piece(scene)["height"]) / dz))
    z = pool + (np.arange(n) + 0.5) * dz
    s = np.clip((h0 - (z - pool - 0.5 * dz)) / dz, 0.0, 1.0)  # a sharp front at h0
    dt = 0.4 * dz * dz * phi / (kappa / mu * 4.5 * scale)
    out, t = [], t0
    for target in times:
        while t < target - 1e-12:
            step = min(dt, target - t)
            Phi = -scale * leverett_j(np.minimum(s, 1.5)) + rho0 * g * z
            dPhi = np.diff(Phi)
            kr = np.clip(np.where(dPhi > 0, s[1:], s[:-1]), 0.0, 1.0) ** 3
            flux = np.zeros(n + 1)  # volume flux a unit area, upward, at the cells' faces
            flux[1:n] = -kappa / mu * kr * dPhi / dz
            d0 = Phi[0] - (-scale * leverett_j(1.0) + rho0 * g * pool)
            kr0 = 1.0 if d0 < 0 else min(max(s[0], 0.0), 1.0) ** 3
            flux[0] = -kappa / mu * kr0 * d0 / (0.5 * dz)
            s += step / (phi * dz) * (flux[:-1] - flux[1:])
            t += step
        out.append(float(s.sum() * dz))
    return np.array(out)


def lucas_washburn(h0, t0, times, scene):
    """Lucas-Washburn with gravity (a sharp front, the suction P_c(0) behind it, the full
    permeability): h' = A / h - B, from h0 at t0; A = kappa P_c(0) / (mu phi), B = kappa rho0 g /
    (mu phi). Integrated by small steps (the implicit closed form needs a root). h0 must be
    above 0: at 0 the suction term is infinite (h' = A / h), and a step from there went below
    the pool and on down (the full studies' errors of 2026-11-29 to -12-06, negative)."""
    if not h0 > 0:
        raise ValueError(f"Lucas-Washburn from a wetted height of {h0} m: it starts above 0")
    cap, fl = scene["capillary"], scene["fluid"]
    kappa, phi = cap["permeability"], cap["porosity"]
    mu, rho0 = max(fl["viscosity"], 1e-6), fl.get("rest_density", 1000.0)
    g = -scene.get("simulation", {}).get("gravity", [0, 0, -9.81])[2]
    pc0 = cap["sigma"] * leverett_j(0.0) / math.sqrt(kappa / phi)
    A, B = kappa * pc0 / (mu * phi), kappa * rho0 * g / (mu * phi)
    h, t, out = h0, t0, []
    for target in times:
        while t < target - 1e-12:
            step = min(1e-5, target - t)
            k1 = A / h - B
            k2 = A / (h + 0.5 * step * k1) - B
            h += step * k2
            t += step
        out.append(h)
    return np.array(out), math.sqrt(2 * A)


def wicking_error(run_dir, scene):
    """The wetted height after the dip's slosh (from t1 = 0.1 s, or the first snapshot after it
    with the strip wet) against Lucas-Washburn with gravity started from the run's height there, RMS over the snapshots relative to its height at
    the end; the same against the 1-D Darcy flow of the model's law with the foot held saturated
    (darcy_1d_error: the discrete strip's front stays sharp, nearer Lucas-Washburn); the exponent
    and the prefactor of h ~ A t^n (fitted while 5 mm < h < 0.3 of the equilibrium height) and
    Lucas-Washburn's prefactor beside them."""
    pool = scene["fluid"]["block"][0]["max"][2]
    contact = 0.01  # the foot reaches the pool at 1 m/s after 1 cm
    series = [wetted_height(p, scene, pool) for p in frames(run_dir)]
    t1 = 0.1
    series = [(t, h) for t, h in series if t >= t1 - 1e-9]
    # From the first of them with the front in the strip: Lucas-Washburn cannot start from 0,
    # and the full strip is still dry at t1 (64 courses on the CPU: wet from 0.12 s).
    series = series[next((i for i, (_, h) in enumerate(series) if h > 0), len(series)):]
    if len(series) < 5:
        raise SystemExit(f"{run_dir}: {len(series)} snapshots after {t1} s with the strip wet")
    ts, hs = np.array([t for t, _ in series]), np.array([h for _, h in series])
    ref = darcy_1d(hs[0], ts[0], ts[1:], scene, pool)
    lw, a_lw = lucas_washburn(hs[0], ts[0], ts[1:], scene)
    error = float(np.sqrt(np.mean((hs[1:] - lw) ** 2)) / lw[-1])
    cap, fl = scene["capillary"], scene["fluid"]
    h_eq = cap["sigma"] * leverett_j(0.0) / math.sqrt(cap["permeability"] / cap["porosity"]) / (
        fl.get("rest_density", 1000.0) * 9.81)
    keep = (hs > 0.005) & (hs < 0.3 * h_eq)
    lt, lh = np.log(ts[keep] - contact), np.log(hs[keep])
    n = float(np.polyfit(lt, lh, 1)[0]) if keep.sum() >= 3 else float("nan")
    prefactor = float(np.exp(np.mean(lh - 0.5 * lt))) if keep.sum() else float("nan")
    return error, len(ref), {
        "exponent": round(n, 4), "prefactor": round(prefactor, 5), "prefactor_lw": round(a_lw, 5),
        "darcy_1d_error": float(np.sqrt(np.mean((hs[1:] - ref) ** 2)) / ref[-1]),
        "height_end_m": round(float(hs[-1]), 5), "darcy_1d_end_m": round(float(ref[-1]), 5),
        "lw_end_m": round(float(lw[-1]), 5)}


def rest_grid_interpolate(rest, x, layer, q_rest, q_layer):
    """Positions at the rest positions q_rest (each in layer q_layer) of a knit whose points of
    each layer lie on a rectilinear rest grid (a flat patch): bilinear in the grid's cells."""
    out = np.full((len(q_rest), 3), np.nan)
    for L in np.unique(q_layer):
        mine = layer == L
        u, v = np.round(rest[mine, 0], 9), np.round(rest[mine, 1], 9)
        us, vs = np.unique(u), np.unique(v)
        if len(us) * len(vs) != mine.sum():
            raise SystemExit(f"layer {L}'s rest positions are no rectilinear grid")
        grid = np.empty((len(vs), len(us), 3))
        grid[np.searchsorted(vs, v), np.searchsorted(us, u)] = x[mine]
        want = q_layer == L
        qu = np.clip(q_rest[want, 0], us[0], us[-1])
        qv = np.clip(q_rest[want, 1], vs[0], vs[-1])
        i = np.clip(np.searchsorted(us, qu) - 1, 0, len(us) - 2)
        j = np.clip(np.searchsorted(vs, qv) - 1, 0, len(vs) - 2)
        fu = ((qu - us[i]) / (us[i + 1] - us[i]))[:, None]
        fv = ((qv - vs[j]) / (vs[j + 1] - vs[j]))[:, None]
        out[want] = ((1 - fu) * (1 - fv) * grid[j, i] + fu * (1 - fv) * grid[j, i + 1]
                     + (1 - fu) * fv * grid[j + 1, i] + fu * fv * grid[j + 1, i + 1])
    return out


def knit_state(path):
    with h5py.File(path, "r") as f:
        state = {"t": float(f.attrs["time"]),
                 "x": f["knit/position"][...].astype(np.float64),
                 "rest": f["knit/rest_position"][...].astype(np.float64),
                 "layer": f["knit/layer"][...]}
        if "fluid_mass" in f["knit"]:
            state["absorbed"] = float(f["knit/fluid_mass"][...].astype(np.float64).sum())
    return state


def knit_deviation(run_dir, ref_dir, width):
    """The RMS over snapshots (t > 0) and points of |x - x_ref(rest)| over the piece's width,
    the reference interpolated at each point's rest position; snapshots matched by time."""
    ref = {round(frame_time(p), 9): p for p in frames(ref_dir)}
    sq, n = [], 0
    for path in frames(run_dir):
        t = round(frame_time(path), 9)
        if t <= 0 or t not in ref:
            continue
        a, b = knit_state(path), knit_state(ref[t])
        at = rest_grid_interpolate(b["rest"], b["x"], b["layer"], a["rest"], a["layer"])
        sq.append(np.mean(np.sum((a["x"] - at) ** 2, axis=1)))
        n += 1
    if n < 3:
        raise SystemExit(f"{run_dir} and {ref_dir}: {n} snapshots at the same times")
    return math.sqrt(float(np.mean(sq))) / width, n


def drape_error(run_dir, scene):
    """Nothing to compare alone: the run is compared with the case's converged run."""
    return float("nan"), 0, {"_ref": run_dir, "_compare": drape_compare}


def drape_compare(run_dir, ref_dir, scene):
    error, n = knit_deviation(run_dir, ref_dir, piece(scene)["width"])
    return error, n, {}


def absorbed_series(run_dir):
    out = []
    for path in frames(run_dir):
        with h5py.File(path, "r") as f:
            out.append((float(f.attrs["time"]),
                        float(f["knit/fluid_mass"][...].astype(np.float64).sum()),
                        float(f["fluid/mass"][...].astype(np.float64).sum()),
                        float(f.attrs.get("outflow_mass", 0.0))))
    return np.array(out)


def pour_error(run_dir, scene):
    """The mass book at the end: (free + absorbed + outflowed) against the start's free mass (the
    paper's model counts fluid still simulated as absorbed too: its book does not close)."""
    s = absorbed_series(run_dir)
    start = s[0, 2] + s[0, 1] + s[0, 3]
    book = abs(s[-1, 1] + s[-1, 2] + s[-1, 3] - start) / start
    return float("nan"), 0, {"_ref": run_dir, "_compare": pour_compare,
                             "mass_book_error": float(book),
                             "absorbed_end_kg": round(float(s[-1, 1]), 6)}


def pour_compare(run_dir, ref_dir, scene):
    """The absorbed mass against time (RMS over the snapshots, relative to the reference's
    largest), and the knit's points (as the drape's) as an extra."""
    a, b = absorbed_series(run_dir), absorbed_series(ref_dir)
    n = min(len(a), len(b))
    if not np.allclose(a[:n, 0], b[:n, 0], rtol=1e-6):
        raise SystemExit(f"{run_dir} and {ref_dir}: snapshots at different times")
    error = float(np.sqrt(np.mean((a[:n, 1] - b[:n, 1]) ** 2)) / max(b[:n, 1].max(), 1e-30))
    position, _ = knit_deviation(run_dir, ref_dir, piece(scene)["width"])
    return error, n, {"knit_position_error": position}
