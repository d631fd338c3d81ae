#!/usr/bin/python3
"""What accuracy costs in time (P7): a reference case run at several settings of one axis, the
rest as its scene has them; each run's error against the known answer beside its wall time.

    jobs/studies/accuracy.py [--full] [--exe KNITFLOW] [--device cpu|cuda] [--out DIR]
                             [--case CASE[,CASE...]|all] [--axis AXIS|all] [--set KEY=VALUE]...
                             [--plot CSV...]

Writes DIR/CASE_AXIS.csv (a row a run: the axis's value, the error, wall seconds, steps,
particles, knit points, peak memory, device, commit, and the case's own measures),
DIR/CASE_AXIS.png (error against wall time, and against the axis), and prints the observed order
of convergence (the least-squares slope of log error over log resolution) for the resolution
axis. --axis all runs every axis of the case (a setting met twice runs once) and adds
DIR/CASE_pareto.png: every run's error against its wall time, coloured by axis, with the Pareto
front (the runs no other beats on both). --case all --axis all: every study. --set KEY=VALUE
(repeatable) sweeps on another base, each row recording it in `extra`. Without --full, the
small version: minutes on two CPU cores; --full, the sizes a GPU takes. --plot redraws the plots
of earlier CSVs (one case's) without running.

Cases (fluid_cases.py, knit_cases.py) and their axes (one at a time, the rest as the case's
scene has them, at the case's base resolution):
  hydrostatic  water at rest in a tank (scenes/hydrostatic.toml): the pressure profile's RMS
               error over rho0 g H, averaged over the last 0.2 s.
               spacing, sound_speed, cfl, kernel, support, density, precision, neighbour_list,
               shifting, artificial_viscosity (Monaghan's alpha, 0 or 0.01), quality
  dambreak     scenes/dambreak.toml to 0.3 s: the surge front (at T + a fitted release delay)
               and the residual height against Martin & Moyce (1952), RMS relative deviation;
               the spacing axis also against its finest run (self_error). Axes as hydrostatic's.
  sloshing     scenes/studies/sloshing.toml: water set moving along a closed tank; the period
               of a damped cosine fitted to its centre of mass along x over 2 s against the
               first standing wave's (linear theory), relative; the decay beside it.
               spacing, sound_speed, support (2, 2.5, 3), cfl, kernel, density,
               neighbour_list, shifting, quality (its
               scene has the artificial viscosity at 0.01: the summation's noise runs away
               without it)
  catenary     scenes/studies/catenary.toml: the settled strip's centre line against the
               catenary of its span and arc length, the largest deviation over the span.
               stitches (wales along the strip), spring_factor (the knit's step), precision
  wicking      scenes/wicking.toml: the wetted height from 0.1 s against Lucas-Washburn with
               gravity (a sharp front, the suction P_c(0) behind it), RMS over its height at the
               end; beside it the fitted exponent and prefactor of h ~ A t^n (prefactor_lw:
               Lucas-Washburn's) and the 1-D Darcy flow of the same law with a saturated foot
               (darcy_1d_error).
               stitches (courses up the strip, 8 courses a wale), substeps, cfl
  drape        scenes/drape.toml: the knit's points against the case's reference run (the
               finest stitches), interpolated at each point's rest position, RMS over snapshots
               and points over the square's width.
               stitches (wales = courses), spring_factor, substeps
  pour         scenes/pour.toml: the absorbed mass against time against the reference run (the
               finest stitches), RMS over the reference's largest; the knit's points as the
               drape's (knit_position_error); the mass book at the end (mass_book_error: free +
               absorbed + outflowed against the start; the paper's absorption counts fluid that
               is still simulated, the conserving one closes).
               stitches, spacing (the fluid's), substeps, absorption (paper, conserving), cfl
"""
import argparse
import json
import math
import os
import sys
import tomllib
from dataclasses import dataclass, field

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fluid_cases  # noqa: E402
import knit_cases  # noqa: E402
from study_io import (ROOT, applied, commit, knit_points, particles, read_rows, run,  # noqa: E402
                      steps, write_csv)
from study_plots import pareto_front, plot, plot_pareto  # noqa: E402

# The fluid's settings, every fluid case's axes beside spacing and sound speed.
FLUID_AXES = {
    "cfl": [0.4, 0.3, 0.2, 0.1],
    "kernel": ["spiky", "cubic", "wendland"],
    "support": [1.5, 2.0, 2.5, 3.0],
    "density": ["summation", "continuity"],
    "precision": ["float", "double"],
    "neighbour_list": ["off", "on", "verlet"],
    "shifting": ["off", "fickian"],
    "artificial_viscosity": [0.0, 0.01],
    # [solver] quality's presets, on the base spacing (preview twice it, reference half).
    "quality": ["preview", "production", "reference"],
}

# A setting's scene key (a case may name its own: the stitches of its piece).
KEYS = {"spacing": "fluid.spacing", "cfl": "solver.cfl", "kernel": "solver.kernel",
        "support": "fluid.support", "sound_speed": "fluid.speed_of_sound",
        "density": "solver.density", "precision": "simulation.precision",
        "neighbour_list": "solver.neighbour_list", "quality": "solver.quality",
        "substeps": "knit.substeps", "spring_factor": "knit.spring_factor",
        "absorption": "capillary.model", "shifting": "solver.shifting",
        "artificial_viscosity": "fluid.artificial_viscosity"}


# The knit cases' snapshots without the yarns' polylines (the errors read the points; the
# yarns' writing would be most of a run's output time).
NO_YARNS = "knit.yarn_samples=0"


def square_stitches(n):
    return [f"knit.piece.0.wales={n}", f"knit.piece.0.courses={n}"]


@dataclass
class Case:
    scene: str
    error: object  # (run_dir, scene) -> (error, points, extra)
    resolution: str  # the axis refinement runs along (its order is printed)
    axes: dict  # axis -> values, or {"small": values, "full": values}
    base: dict  # {"small": overrides, "full": overrides}: the others' resolution
    fixed: dict = field(default_factory=lambda: {"small": [], "full": []})
    keys: dict = field(default_factory=dict)  # axis -> value -> overrides, beyond KEYS
    # "self": every run compared with the reference run (the resolution axis's finest at the
    # base's other settings), by the extra "_compare".
    reference: str = ""

    def values(self, axis, full):
        if axis not in self.axes:
            raise SystemExit(f"this case has no axis '{axis}' (known: {', '.join(self.axes)})")
        v = self.axes[axis]
        return v["full" if full else "small"] if isinstance(v, dict) else v

    def setting(self, axis, value):
        if axis in self.keys:
            return self.keys[axis](value)
        if axis not in KEYS:
            raise SystemExit(f"unknown axis '{axis}' (known: {', '.join(KEYS)})")
        return [f"{KEYS[axis]}={json.dumps(value)}"]

    def base_for(self, axis, full):
        return [] if axis == self.resolution else self.base["full" if full else "small"]


def fluid_axes(spacing, sound_speeds):
    return {"spacing": spacing, "sound_speed": sound_speeds, **FLUID_AXES}


CASES = {
    "hydrostatic": Case(
        "scenes/hydrostatic.toml", fluid_cases.hydrostatic_case_error, "spacing",
        fluid_axes({"small": [0.02, 0.015, 0.0125, 0.01], "full": [0.02, 0.01, 0.005, 0.0025]},
                   [10.0, 20.0, 40.0]),
        {"small": ["fluid.spacing=0.015"], "full": ["fluid.spacing=0.005"]}),
    # A whole number of particles across the column (small 8, 10, 16, 20; full 10 to 80; a =
    # 0.2 m).
    "dambreak": Case(
        "scenes/dambreak.toml", fluid_cases.dambreak_error, "spacing",
        fluid_axes({"small": [0.025, 0.02, 0.0125, 0.01], "full": [0.02, 0.01, 0.005, 0.0025]},
                   [15.0, 30.0, 60.0]),
        {"small": ["fluid.spacing=0.0125"], "full": ["fluid.spacing=0.005"]},
        fixed={"small": ["simulation.end_time=0.3", "output.interval=0.01"],
               "full": ["simulation.end_time=0.3", "output.interval=0.01"]}),
    # A whole number of particles along the tank (0.4 m), across the slice (0.06 m) and up the
    # fill (0.2 m): 0.015 m (the small study's until 2026-12-01) left 1 cm of the tank's length
    # and 5 mm of the fill empty.
    "sloshing": Case(
        "scenes/studies/sloshing.toml", fluid_cases.sloshing_error, "spacing",
        {"spacing": {"small": [0.02, 0.01], "full": [0.02, 0.01, 0.005, 0.0025]},
         "sound_speed": [10.0, 20.0, 40.0],
         # The support in spacings sets the period's error here, not the spacing, with a kernel that
         # does not pair (the scene's Wendland; the cubic spline pairs past 2: VALIDATION).
         "support": [2.0, 2.5, 3.0, 3.5, 4.0],
         **{k: FLUID_AXES[k]
            for k in ("cfl", "kernel", "density", "neighbour_list", "shifting", "quality")}},
        {"small": ["fluid.spacing=0.02"], "full": ["fluid.spacing=0.005"]}),
    # Wales along the strip.
    "catenary": Case(
        "scenes/studies/catenary.toml", knit_cases.catenary_error, "stitches",
        {"stitches": {"small": [15, 30, 60], "full": [15, 30, 60, 120, 240]},
         "spring_factor": [1.0, 0.5, 0.25], "precision": ["float", "double"]},
        {"small": ["knit.piece.0.wales=30"], "full": ["knit.piece.0.wales=60"]},
        fixed={"small": ["output.interval=4.0"], "full": ["output.interval=4.0"]},
        keys={"stitches": lambda n: [f"knit.piece.0.wales={n}"]}),
    # Courses up the strip, 8 to a wale (3 cm by 16 cm); the pool's fluid as the scene has it. The
    # knit's step falls with its spacing: 128 courses to 1.2 s take ~2 min on an H200.
    "wicking": Case(
        "scenes/wicking.toml", knit_cases.wicking_error, "stitches",
        {"stitches": {"small": [32, 64], "full": [32, 64, 128]},
         "substeps": [1, 2, 4, 8], "cfl": [0.4, 0.2, 0.1]},
        {"small": ["knit.piece.0.courses=32", "knit.piece.0.wales=4"],
         "full": ["knit.piece.0.courses=64", "knit.piece.0.wales=8"]},
        fixed={"small": ["simulation.end_time=0.8", "output.interval=0.02", NO_YARNS],
               "full": ["simulation.end_time=1.2", "output.interval=0.02", NO_YARNS]},
        keys={"stitches": lambda n: [f"knit.piece.0.courses={n}",
                                     f"knit.piece.0.wales={n // 8}"]}),
    "drape": Case(
        "scenes/drape.toml", knit_cases.drape_error, "stitches",
        {"stitches": {"small": [16, 24, 32, 48], "full": [32, 64, 128, 256]},
         "spring_factor": [1.0, 0.5, 0.25], "substeps": [1, 2, 4]},
        {"small": square_stitches(24), "full": square_stitches(128)},
        fixed={"small": ["simulation.end_time=0.4", "output.interval=0.05", NO_YARNS],
               "full": ["simulation.end_time=1.0", "output.interval=0.05", NO_YARNS]},
        keys={"stitches": square_stitches}, reference="self"),
    # The small pour: a coarser fluid (8x fewer particles) over its first 0.25 s. The knit's
    # "verlet" lists need the coupling's reach (0.8 of the knit's spacing and more) within the
    # fluid's support: 32 stitches and more at the small spacing, 64 at the full.
    "pour": Case(
        "scenes/pour.toml", knit_cases.pour_error, "stitches",
        {"stitches": {"small": [32, 48, 64], "full": [64, 96, 128, 256]},
         "spacing": {"small": [0.02, 0.01], "full": [0.01, 0.005, 0.0035]},
         "substeps": [1, 2, 4, 8], "absorption": ["paper", "conserving"],
         "cfl": [0.4, 0.2, 0.1]},
        {"small": square_stitches(32), "full": square_stitches(128)},
        fixed={"small": ["simulation.end_time=0.25", "output.interval=0.01",
                         "fluid.spacing=0.01", NO_YARNS],
               "full": ["simulation.end_time=0.5", "output.interval=0.02", NO_YARNS]},
        keys={"stitches": square_stitches}, reference="self"),
}


def observed_order(values, errors):
    """The least-squares slope of log error over log value."""
    x, y = np.log(np.asarray(values, float)), np.log(np.asarray(errors, float))
    return float(np.polyfit(x, y, 1)[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--exe", default=os.path.join(ROOT, "build", "cpu", "apps", "knitflow"))
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "studies"))
    ap.add_argument("--case", default="hydrostatic",
                    help=f"a case, several joined by commas, or all ({', '.join(CASES)})")
    ap.add_argument("--axis", default="")
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--set", dest="extra", action="append", default=[], metavar="KEY=VALUE",
                    help="a scene override for every run (an axis swept on another base: the "
                    "sloshing's spacing at support 3); the axis's own setting still wins; "
                    "recorded in the CSV's `extra` column")
    ap.add_argument("--plot", metavar="CSV", nargs="+",
                    help="no runs: the plots of earlier runs' CSVs (a case's rows) into --out")
    a = ap.parse_args()
    if a.plot:
        replot(a.plot, a.out)
        return
    cases = list(CASES) if a.case == "all" else a.case.split(",")
    for case in cases:
        if case not in CASES:
            raise SystemExit(f"unknown case '{case}' (known: {', '.join(CASES)}, all)")
    for case in cases:
        study(a, case)


def replot(paths, out):
    """The plots of CSVs an earlier study wrote (one case; an axis's rows or all of them)."""
    rows = read_rows(paths)
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


def value_text(v):
    return f"{v:g}" if isinstance(v, float) else str(v)


def study(a, name):
    """One case's sweeps (a's axis or all of them)."""
    case = CASES[name]
    size = "full" if a.full else "small"
    scene_path = os.path.join(ROOT, case.scene)
    with open(scene_path, "rb") as f:
        base_scene = tomllib.load(f)
    axis = a.axis or case.resolution
    axes = list(case.axes) if axis == "all" else [axis]
    for ax in axes:
        case.values(ax, a.full)  # refuses an unknown axis before any run
    os.makedirs(a.out, exist_ok=True)
    version = commit()
    done = {}  # a setting met twice (the base in every axis) runs once

    def measure(ax, v):
        overrides = case.fixed[size] + case.base_for(ax, a.full) + a.extra + case.setting(ax, v)
        scene = applied(base_scene, overrides)
        key = json.dumps(scene, sort_keys=True)
        if key not in done:
            out = os.path.join(a.out, f"{name}_{ax}_{value_text(v)}")
            wall, memory, unstable = run(a.exe, scene_path, overrides, out, a.device)
            # A run the solver stopped as unstable: its row says so (no error to measure; its
            # steps and time up to the stop), and the study goes on.
            error, points, extra = (float("nan"), 0, {}) if unstable else case.error(out, scene)
            done[key] = {"particles": particles(out), "knit_points": knit_points(out),
                         "steps": steps(out), "wall_s": round(wall, 3), "error": error,
                         "points": points, "memory_mb": round(memory, 1),
                         "unstable": unstable, **extra}
        return done[key], scene

    reference = None
    if case.reference == "self":
        finest = case.values(case.resolution, a.full)[-1]
        reference, _ = measure(case.resolution, finest)
        print(f"{name}: the reference run is {case.resolution} = {finest} "
              f"({reference['wall_s']:.1f} s)", flush=True)
    every = []
    for ax in axes:
        rows = []
        for v in case.values(ax, a.full):
            result, scene = measure(ax, v)
            r = {"case": name, "axis": ax, "value": v, **result, "device": a.device,
                 "commit": version}
            if a.extra:
                r["extra"] = ";".join(a.extra)
            if reference is not None and not result["unstable"]:
                if result["_ref"] == reference["_ref"]:
                    r["error"], r["points"] = float("nan"), 0  # the reference itself
                else:
                    error, points, extra = result["_compare"](result["_ref"], reference["_ref"],
                                                              scene)
                    r.update(error=error, points=points, **extra)
            rows.append(r)
            print(f"{name} {ax} = {v}: {r['particles']} particles, {r['knit_points']} knit "
                  f"points, {r['steps']} steps, {r['wall_s']:.1f} s, error {r['error']:.4g} "
                  f"({r['points']} points)" + (f"; stopped: {r['unstable']}" if r["unstable"]
                                                else ""), flush=True)
        if ax == "spacing" and "_curves" in rows[-1]:
            # Against our own finest run: how far each coarser one is from where refinement
            # goes (the experiment holds a floor: its scatter, the gate's release).
            coarser = [r for r in rows[:-1] if "_curves" in r]
            for r in coarser:
                r["self_error"] = fluid_cases.self_error(r["_curves"], rows[-1]["_curves"])
            order = observed_order([r["value"] for r in coarser],
                                   [r["self_error"] for r in coarser])
            print(f"{name}: against the finest run, errors "
                  + ", ".join(f"{r['self_error']:.4g}" for r in coarser)
                  + f"; observed order {order:.2f}")
        for r in rows:
            for k in [k for k in r if k.startswith("_")]:
                del r[k]
        write_csv(rows, os.path.join(a.out, f"{name}_{ax}.csv"))
        png = os.path.join(a.out, f"{name}_{ax}.png")
        plot(rows, name, ax, png)
        if ax == case.resolution:
            # Resolution as the spacing (spacing) or as the stitches' inverse (stitches).
            fit = [r for r in rows if math.isfinite(r["error"]) and r["error"] > 0]
            scale = [r["value"] if ax == "spacing" else 1.0 / r["value"] for r in fit]
            if len(fit) >= 2:
                print(f"{name}: observed order {observed_order(scale, [r['error'] for r in fit]):.2f}"
                      f" over {ax} {fit[0]['value']:g}..{fit[-1]['value']:g}")
        print(f"wrote {os.path.join(a.out, f'{name}_{ax}.csv')} and {png}")
        every += rows
    if axis == "all":
        write_csv(every, os.path.join(a.out, f"{name}_all.csv"))
        plot_pareto(every, name, os.path.join(a.out, f"{name}_pareto.png"))
        front = pareto_front(every)
        print(f"{name}: Pareto front " + ", ".join(
            f"{r['axis']}={r['value']} ({r['wall_s']:.1f} s, {r['error']:.3g})" for r in front))


if __name__ == "__main__":
    main()
