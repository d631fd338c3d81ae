#!/usr/bin/python3
"""The cost model of a run (P7): fitted to the accuracy studies' timings, checked against them.

    jobs/studies/cost_model.py --exe KNITFLOW CSV [CSV ...] [--out FILE.toml]

A run's wall time on a device is predicted as (src/domain/CostModel.hpp)

    T = start + S (f (step + (support / 2)^q (pair_step + fluid N_fluid) + boundary N_boundary)
                   + knit_step
                   + substeps (knit_substep + N_knit (knit + self_contact? + coupling?)
                               + coupling? coupling_substep)
                   + coupling? coupling_step
                   + conserving? darcy_substeps (conserving_substep + N_knit conserving))
              + knit_start + frames output (N_fluid + N_boundary + N_knit)

S the run's steps, N the particles, the support and the settings that carry a factor f as
`knitflow plan` gives them (its "model" line: S = end_time over the CFL step at the fluid's fall
speed from its top, none where the scene damps its motion toward rest): f the product of a factor
a setting (the continuity density, the neighbour lists "on", "verlet" in a settling scene and in
a flowing one, double precision, particle shifting, the artificial viscosity) on a whole step (on
a GPU a small step is mostly its kernels' launches, which a setting changes with its passes); q
the pairs' exponent (3 where a pair costs as a pair; fitted on a grid of 1-4 where the runs have
several supports). start, step, pair_step (a step's cost that grows with the pairs a particle
meets but not with the particles: on a GPU a small run's passes last as long as a particle's walk
over its neighbours, as the support's runs show), fluid and boundary are fitted by least squares
on relative error over the fluid's runs without such settings; each setting's factor is then the
geometric mean over the cases of what each case's runs ask for (one case's many runs do not
outvote another's few); the knit's coefficients (a substep's fixed cost, a point's a substep, the
self-contact's and the knit-fluid coupling's a point a substep where the scene has them, the
coupling's fixed cost a substep and a step, the conserving absorption's a point and its fixed
cost a Darcy substep: the plan's "knit terms"; the knit's fixed cost a step and a run) over the
runs with a knit, the fluid's part of them as fitted, making the worst run's relative error
smallest (minimax: the plan promises a bound). Every study run's prediction is printed against
its measured time; --out writes the device's table into the model file (src/domain/CostModel.toml,
which the app compiles in) in its place, keeping the other devices'.
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

def parsed(text):
    """A CSV cell as the study wrote it: an integer, a number or a word."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def overrides_of(row, full):
    """The --set overrides the study gave this row's run."""
    case = accuracy.CASES[row["case"]]
    size = "full" if full else "small"
    extra = [o for o in (row.get("extra") or "").split(";") if o]  # accuracy.py --set
    return (case.fixed[size] + case.base_for(row["axis"], full) + extra
            + case.setting(row["axis"], parsed(row["value"])))


def plan_of(exe, case, overrides):
    """The model's inputs as `knitflow plan` gives them: its "model" line (particles, support,
    the run's steps, the settings that carry a factor)."""
    cmd = [exe, "plan", os.path.join(accuracy.ROOT, accuracy.CASES[case].scene)]
    for o in overrides:
        cmd += ["--set", o]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    m = re.search(r"model\s+fluid (\d+), boundary (\d+), knit (\d+), support (\S+), steps (\d+), "
                  r"settings (\S+?), substeps (\d+), knit terms (\S+?), darcy substeps (\d+), "
                  r"frames (\d+)", text)
    if not m:
        raise SystemExit(f"{' '.join(cmd)}: no model line in the plan")
    return {"fluid": int(m.group(1)), "boundary": int(m.group(2)), "knit": int(m.group(3)),
            "support": float(m.group(4)), "steps": float(m.group(5)),
            "settings": [] if m.group(6) == "none" else m.group(6).split(","),
            "substeps": int(m.group(7)),
            "terms": [] if m.group(8) == "none" else m.group(8).split(","),
            "darcy": float(m.group(9)), "frames": float(m.group(10))}


def step_factor(row, factors):
    f = 1.0
    for name in row["settings"]:
        f *= factors.get(name, 1.0)
    return f


def step_cost(c, row):
    """The fluid's part of a step before its settings' factor (none without fluid)."""
    if row["Nf"] == 0 and row["Nb"] == 0:
        return 0.0
    return c[1] + pairs(row, c[6]) * (c[5] + c[2] * row["Nf"]) + c[3] * row["Nb"]


def pairs(row, q):
    """What the support's neighbours cost against support 2: (support / 2)^q. q = 3 where a pair
    costs as a pair (the neighbours a particle meets); a GPU fits less (its cells' candidates are
    longer runs at a wider support: 1.9x a step's time at support 3 for 3.4x the pairs)."""
    return (row["support"] / 2.0) ** q


KNIT_TERMS = ["knit_substep_s", "knit_s", "self_contact_s", "coupling_s", "coupling_step_s",
              "conserving_s", "coupling_substep_s", "knit_step_s", "conserving_substep_s",
              "knit_start_s"]


def knit_columns(row):
    """The knit's part of a step as a sum of its coefficients (KNIT_TERMS[:-1]) times these."""
    n, sub, terms = row["Nk"], row["substeps"], row["terms"]
    if n == 0:
        return np.zeros(len(KNIT_TERMS))
    coupled = "knit_coupling" in terms
    darcy = max(row["darcy"], 1.0) * ("absorption_conserving" in terms)
    return np.array([sub, sub * n, sub * n * ("knit_self_contact" in terms), sub * n * coupled,
                     coupled, n * darcy, sub * coupled, 1.0, darcy], float)


def knit_run_columns(row):
    """knit_columns a step times the run's steps, and the knit's start (once a run: its
    building, the pore network, the first lists)."""
    if row["Nk"] == 0:
        return np.zeros(len(KNIT_TERMS))
    return np.append(row["S"] * knit_columns(row), 1.0)


def output_column(row):
    """The snapshots' writing: frames times every particle."""
    return row["frames"] * (row["Nf"] + row["Nb"] + row["Nk"])


def predict(c, row, factors, knit):
    return (c[0] + row["S"] * step_factor(row, factors) * step_cost(c, row)
            + float(knit_run_columns(row) @ knit) + c[4] * output_column(row))


def nonnegative_lstsq(A, y):
    """Least squares with every coefficient >= 0: a column whose coefficient comes out negative
    is dropped (its term 0) and the rest fitted again."""
    keep = [j for j in range(A.shape[1]) if np.any(A[:, j])]
    while True:
        x = np.zeros(A.shape[1])
        if keep:
            x[keep], *_ = np.linalg.lstsq(A[:, keep], y, rcond=None)
        bad = [j for j in keep if x[j] < 0]
        if not bad:
            return x
        keep.remove(min(bad, key=lambda j: x[j]))


def minimax_nonnegative(A, y, rounds=500):
    """x >= 0 making the largest |A x - y| small (Lawson's iteration: least squares whose row
    weights grow with their residuals; from the plain least squares, kept where it is better)."""
    x = best = nonnegative_lstsq(A, y)
    worst = np.max(np.abs(A @ x - y))
    u = np.full(len(y), 1.0 / len(y))
    for _ in range(rounds):
        s = np.sqrt(u)
        x = nonnegative_lstsq(A * s[:, None], y * s)
        r = np.abs(A @ x - y)
        if r.max() < worst:
            best, worst = x, r.max()
        u = u * r
        if not u.sum() > 0:
            break
        u /= u.sum()
    return best


def fit(rows):
    """The fluid's coefficients over the fluid runs without settings, each setting's factor from
    its own runs, then the knit's coefficients over the knit's runs (the fluid's part of them as
    the fluid's fit predicts it); least squares on relative error."""
    fluid = [r for r in rows if r["Nk"] == 0]
    base = [r for r in fluid if not r["settings"]]
    # step_cost's columns, the support's pairs included (fitted as 1 until 2026-11-29 while the
    # prediction scaled them: the support's runs pulled the fluid's coefficient off), for each
    # exponent q of the pairs on a grid; the q whose worst base run is nearest kept (3 where the
    # runs have one support: the plain pair count).
    w = np.array([1.0 / r["wall"] for r in base])
    y = np.array([r["wall"] for r in base])
    best = None
    supports = {r["support"] for r in base}
    for q in (np.arange(1.0, 4.001, 0.05) if len(supports) > 1 else [3.0]):
        A = np.array([[1.0, r["S"], r["S"] * pairs(r, q) * r["Nf"], r["S"] * r["Nb"],
                       output_column(r), r["S"] * pairs(r, q)] for r in base])
        x = nonnegative_lstsq(A * w[:, None], y * w)
        worst = np.max(np.abs((A @ x) * w - 1.0))
        if best is None or worst < best[0] - 1e-12:
            best = (worst, np.append(x, round(float(q), 2)))
    c = best[1]
    asks = {}
    for r in fluid:
        if len(r["settings"]) == 1:  # a setting's own runs ask for its factor
            step = r["S"] * step_cost(c, r)
            rest = r["wall"] - c[0] - c[4] * output_column(r)
            asks.setdefault(r["settings"][0], {}).setdefault(r["case"], []).append(
                max(rest, 0.05 * step) / step)
    factors = {k: float(np.exp(np.mean([np.mean(np.log(v)) for v in by_case.values()])))
               for k, by_case in asks.items()}
    knit = np.zeros(len(KNIT_TERMS))
    knitted = [r for r in rows if r["Nk"] > 0]
    if knitted:
        y = np.array([r["wall"] - c[0] - r["S"] * step_factor(r, factors) * step_cost(c, r)
                      - c[4] * output_column(r) for r in knitted])
        w = np.array([1.0 / r["wall"] for r in knitted])
        A = np.array([knit_run_columns(r) for r in knitted])
        # The worst run's error, not the squares' sum: the plan's promise is a bound.
        knit = minimax_nonnegative(A * w[:, None], y * w)
    return c, factors, knit


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
                if r.get("unstable"):  # stopped by the solver: not the whole run's time
                    print(f"left out: {r['case']} {r['axis']} = {r['value']}, {r['unstable']}")
                    continue
                p = plan_of(a.exe, r["case"], overrides_of(r, a.full))
                r.update(S=p["steps"], settings=p["settings"], support=p["support"],
                         steps=int(float(r["steps"])), Nf=p["fluid"], Nb=p["boundary"],
                         Nk=p["knit"], substeps=p["substeps"], terms=p["terms"],
                         darcy=p["darcy"], frames=p["frames"],
                         wall=float(r["wall_s"]))
                rows.append(r)
    c, factors, knit = fit(rows)
    worst = worst_fluid = 0.0
    print(f"{'case':12} {'axis':15} {'value':>10} {'fluid':>9} {'boundary':>9} {'knit':>7} "
          f"{'steps':>7} {'planned':>7} {'measured':>9} {'predicted':>10} {'off':>6}")
    for r in rows:
        t = predict(c, r, factors, knit)
        off = t / r["wall"] - 1
        worst = max(worst, abs(off))
        if r["Nk"] == 0:
            worst_fluid = max(worst_fluid, abs(off))
        print(f"{r['case']:12} {r['axis']:15} {str(r['value']):>10} {r['Nf']:9d} {r['Nb']:9d} "
              f"{r['Nk']:7d} {r['steps']:7d} {r['S']:7.0f} {r['wall']:9.2f} {t:10.2f} {100 * off:+5.0f}%")
    device = a.device or rows[0].get("device", "device")
    print(f"{device}: t_start {c[0]:.3g} s, a step {c[1]:.3g} s + {c[5]:.3g} s x the pairs "
          f"((support / 2)^{c[6]:.3g}) + "
          f"{c[2]:.3g} s a fluid particle "
          f"+ {c[3]:.3g} s a boundary particle, {c[4]:.3g} s a particle a snapshot; factors "
          + ", ".join(f"{k} x{f:.2f}" for k, f in factors.items())
          + "; knit " + ", ".join(f"{k} {v:.3g}" for k, v in zip(KNIT_TERMS, knit))
          + f"; worst prediction {100 * worst:.0f}% off over {len(rows)} runs, "
          f"{100 * worst_fluid:.0f}% over those without a knit")
    if a.out:
        write_model(a.out, device, c, factors, knit, worst, worst_fluid, a.csv)


def write_model(path, device, c, factors, knit, worst, worst_fluid, sources):
    """The device's table into the model file, the other devices' kept."""
    lines = open(path).read().splitlines() if os.path.exists(path) else []
    kept, skip, at = [], False, None
    for line in lines:
        if line.startswith("["):
            skip = line.strip() == f"[{device}]"
            if skip:
                at = len(kept)  # the new table goes where the old one was
        if not skip:
            kept.append(line)
    after = kept[at:] if at is not None else []
    kept = kept[:at] if at is not None else kept
    while kept and not kept[-1].strip():
        kept.pop()
    table = [f"[{device}]",
             f"# fitted by jobs/studies/cost_model.py to "
             f"{', '.join(os.path.relpath(os.path.abspath(p), accuracy.ROOT) for p in sources)}",
             f"start_s = {c[0]:.6g}", f"step_s = {c[1]:.6g}", f"fluid_s = {c[2]:.6g}",
             f"boundary_s = {c[3]:.6g}", f"output_s = {c[4]:.6g}", f"pair_step_s = {c[5]:.6g}",
             f"pairs_exponent = {c[6]:.3g}"]
    table += [f"{k} = {f:.4g}" for k, f in factors.items()]
    table += [f"{k} = {v:.6g}" for k, v in zip(KNIT_TERMS, knit) if v > 0]
    table.append(f"worst_off = {worst:.3f}")
    table.append(f"worst_off_fluid = {worst_fluid:.3f}")
    with open(path, "w") as f:
        f.write("\n".join(kept + ([""] if kept else []) + table + ([""] if after else [])
                          + after) + "\n")


if __name__ == "__main__":
    main()
