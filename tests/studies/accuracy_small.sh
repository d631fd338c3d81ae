#!/usr/bin/env bash
# P7's small accuracy study in CI: the hydrostatic tank at 4 spacings on the CPU
# (jobs/studies/accuracy.py); its CSV holds a row a spacing, the plot is written, the error falls
# at every refinement and the observed order is the one stated below.
# Usage: accuracy_small.sh KNITFLOW OUTDIR
set -euo pipefail
exe=$1 out=$2
root="$(cd "$(dirname "$0")/../.." && pwd)"
rm -rf "$out"
/usr/bin/python3 "$root/jobs/studies/accuracy.py" --exe "$exe" --out "$out" --case hydrostatic \
  --axis spacing | tee "$out.log"
/usr/bin/python3 - "$out" <<'PY'
import csv, math, os, sys
import numpy as np
out = sys.argv[1]
rows = list(csv.DictReader(open(os.path.join(out, "hydrostatic_spacing.csv"))))
assert len(rows) == 4, f"{len(rows)} rows, not 4"
assert os.path.getsize(os.path.join(out, "hydrostatic_spacing.png")) > 10000, "no plot"
h = [float(r["value"]) for r in rows]
e = [float(r["error"]) for r in rows]
for k in range(1, len(rows)):
    assert e[k] < e[k - 1], f"the error grew from spacing {h[k-1]} to {h[k]}: {e[k-1]} -> {e[k]}"
order = float(np.polyfit(np.log(h), np.log(e), 1)[0])
print(f"observed order {order:.2f}")
# Measured 1.56 over spacings 0.02..0.0075 (errors 2.1%, 1.7%, 0.75%, 0.50% of rho0 g H on the
# 2-core machine; the CPU run is deterministic): between first order (the kernel's truncation
# near the free surface and the walls) and second (its interior). A coarser 0.03 (5 particles
# across the tank) is off the asymptote (11.6%) and left out.
lo, hi = 1.4, 1.75
assert lo <= order <= hi, f"observed order {order:.2f} outside [{lo}, {hi}]"
PY
