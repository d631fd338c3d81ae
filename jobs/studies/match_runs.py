#!/usr/bin/python3
"""Two runs of one scene (say on 1 and on 2 GPUs) compared particle by particle, matched by global
id, frame by frame: for each phase, the count, whether the ids are the same set, and the largest
difference of position and velocity (and of absorbed fluid mass for the knit).

    jobs/studies/match_runs.py RUN_A RUN_B [--frames 1,2]

RUN_A and RUN_B are output directories holding frame_NNNNNN.h5. Exit status 1 if the ids differ
or a frame is missing from one run; the differences are reported, not judged (a chaotic splash
parts two summation orders; the caller states the bound it expects)."""
import argparse
import glob
import os
import sys

import h5py
import numpy as np


def by_id(group, name):
    ids = group["id"][...]
    order = np.argsort(ids, kind="stable")
    return ids[order], group[name][...][order] if name in group else None


def compare(fa, fb):
    rows, ok = [], True
    with h5py.File(fa, "r") as a, h5py.File(fb, "r") as b:
        for phase in ("fluid", "boundary", "knit"):
            if phase not in a or phase not in b or "id" not in a[phase]:
                continue
            ia, pa = by_id(a[phase], "position")
            ib, pb = by_id(b[phase], "position")
            same = ia.shape == ib.shape and np.array_equal(ia, ib)
            ok &= bool(same)
            row = {"phase": phase, "count_a": len(ia), "count_b": len(ib), "same_ids": same}
            if same and len(ia):
                row["max_dx"] = float(np.abs(pa - pb).max())
                row["extent"] = float((pa.max(0) - pa.min(0)).max())
                for field, key in (("velocity", "max_dv"), ("fluid_mass", "max_dm")):
                    va, vb = by_id(a[phase], field)[1], by_id(b[phase], field)[1]
                    if va is not None and vb is not None:
                        row[key] = float(np.abs(va - vb).max())
            rows.append(row)
    return rows, ok


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_a")
    ap.add_argument("run_b")
    ap.add_argument("--frames", default="", help="frame numbers, comma-separated (default: all common)")
    a = ap.parse_args()
    names = lambda d: {os.path.basename(p) for p in glob.glob(os.path.join(d, "frame_*.h5"))}
    na, nb = names(a.run_a), names(a.run_b)
    if a.frames:
        want = {"frame_%06d.h5" % int(f) for f in a.frames.split(",")}
    else:
        want = na | nb
    ok = True
    for name in sorted(want):
        if name not in na or name not in nb:
            print("%s: missing from %s" % (name, a.run_a if name not in na else a.run_b))
            ok = False
            continue
        rows, same = compare(os.path.join(a.run_a, name), os.path.join(a.run_b, name))
        ok &= same
        for r in rows:
            extra = "  ".join("%s %.3g" % (k, r[k]) for k in ("max_dx", "max_dv", "max_dm", "extent") if k in r)
            print("%s %-8s %8d / %8d ids %s  %s" % (name, r["phase"], r["count_a"], r["count_b"],
                                                    "same" if r["same_ids"] else "DIFFER", extra))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
