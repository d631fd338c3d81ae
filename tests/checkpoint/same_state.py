#!/usr/bin/python3
"""Two snapshot files hold the same state bit for bit: the same time and step, the same phases and
fields, every value equal row for row once each phase's rows are put in id order (on N ranks a
run's rows come in its ranks' order, which its history sets). The scene text is not compared (it
records the command's overrides, --output among them), nor the field "rank": which rank holds a
particle follows the balance, which measured wall times steer (the state does not depend on it:
sums go in id order on every partition).

    same_state.py A.h5 B.h5
"""
import sys

import h5py
import numpy as np


def phases(f):
    return {k: f[k] for k in f if isinstance(f[k], h5py.Group)}


def main():
    a, b = (h5py.File(p, "r") for p in sys.argv[1:3])
    bad = []
    for key in ("time", "step"):
        if a.attrs[key] != b.attrs[key]:
            bad.append(f"{key}: {a.attrs[key]} against {b.attrs[key]}")
    pa, pb = phases(a), phases(b)
    if sorted(pa) != sorted(pb):
        bad.append(f"phases {sorted(pa)} against {sorted(pb)}")
    for name in sorted(set(pa) & set(pb)):
        ga, gb = pa[name], pb[name]
        if sorted(ga) != sorted(gb):
            bad.append(f"{name}: fields {sorted(ga)} against {sorted(gb)}")
            continue
        oa = np.argsort(ga["id"][...], kind="stable") if "id" in ga else slice(None)
        ob = np.argsort(gb["id"][...], kind="stable") if "id" in gb else slice(None)
        for field in sorted(f for f in ga if f != "rank"):
            x, y = ga[field][...][oa], gb[field][...][ob]
            if x.shape != y.shape or x.tobytes() != y.tobytes():
                diff = "shape" if x.shape != y.shape else f"{np.count_nonzero(x != y)} values"
                bad.append(f"{name}/{field}: {diff} differ")
    for line in bad:
        print(f"{sys.argv[1]} vs {sys.argv[2]}: {line}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
