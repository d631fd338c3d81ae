#!/usr/bin/env python3
"""Repeated timings of a study's runs (P7): each run's median wall time over several passes of
the same study, put on the speed the machine had when a stored CSV was measured.

    jobs/studies/repeated.py --like STORED.csv --out OUT.csv PASS.csv [PASS.csv ...] [--add]

Why: the 2-core VM's speed varies by up to 1.75x between hours and identical runs within one
hour by +-15% (docs/VALIDATION.md, P7), so one timing a point cannot fit a CPU's cost model to the
issue's 25%, and timings of another hour cannot join a stored CSV as they are. So each (case,
axis, value) of the passes takes the median of its wall times, and every median is scaled by one
factor, the machine's speed then against now: the median over those rows of STORED's time over
the passes' median (a median, so that the stored rows' own noise, the reason for the passes,
moves it little). OUT is STORED with the passes' rows put in their place (the others as they
were), each with `wall_runs_s` (the passes' own times, ';'-separated) and `speed_scale` beside
its scaled `wall_s`. With --add, the passes' rows that STORED lacks (a new axis or value) are
appended to it, scaled alike, and the rows both hold (at least three) only set the factor: they
stay as stored.
"""
import argparse
import csv
import statistics


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("passes", nargs="+", help="the passes' CSVs (accuracy.py's, any axes)")
    ap.add_argument("--like", required=True, help="the stored CSV the medians join")
    ap.add_argument("--out", required=True)
    ap.add_argument("--add", action="store_true",
                    help="append the passes' rows STORED lacks; those both hold set the scale, kept")
    a = ap.parse_args()
    stored = read(a.like)
    runs = {}  # (case, axis, value) -> [wall_s, ...], in the passes' order
    first = {}
    for path in a.passes:
        for r in read(path):
            if r.get("unstable"):
                raise SystemExit(f"{path}: {r['axis']} = {r['value']} stopped unstable")
            k = (r["case"], r["axis"], r["value"])
            runs.setdefault(k, []).append(float(r["wall_s"]))
            first.setdefault(k, r)
    medians = {k: statistics.median(ts) for k, ts in runs.items()}
    then = {(r["case"], r["axis"], r["value"]): float(r["wall_s"]) for r in stored}
    missing = set(runs) - set(then)
    if missing and not a.add:
        raise SystemExit(f"rows of the passes not in {a.like}: {sorted(missing)}")
    common = [k for k in runs if k in then]
    if len(common) < 3:
        raise SystemExit(f"{len(common)} rows of the passes in {a.like}: at least 3 set the scale")
    ratios = sorted(then[k] / medians[k] for k in common)
    scale = statistics.median(ratios)
    print(f"{a.like} against the passes' medians, row by row: "
          + ", ".join(f"{x:.3f}" for x in ratios) + f"; scale (their median) {scale:.4f}")
    def scaled(k, was):
        """The passes' row k with its scaled median beside its own times."""
        r = dict(first[k], wall_s=round(medians[k] * scale, 3),
                 wall_runs_s=";".join(f"{t:.3f}" for t in runs[k]), speed_scale=round(scale, 4))
        print(f"  {k[0]} {k[1]} = {k[2]}: {r['wall_runs_s']} s -> {r['wall_s']} s ({was})")
        return r

    out = []
    for r in stored:
        k = (r["case"], r["axis"], r["value"])
        out.append(scaled(k, f"was {then[k]:.3f}") if k in runs and not a.add else r)
    out += [scaled(k, "new") for k in runs if k not in then]  # --add: in the passes' order
    fields = list(dict.fromkeys(f for r in out for f in r))
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
