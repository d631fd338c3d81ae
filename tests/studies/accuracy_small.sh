#!/usr/bin/env bash
# P7's small accuracy studies in CI: CASE along its resolution axis (hydrostatic: the tank at 4
# spacings; dambreak: the 3D dam break at 8, 10, 16, 20 particles across the column, against
# Martin & Moyce; catenary: the hanging strip at 15, 30, 60 stitches) on the CPU
# (jobs/studies/accuracy.py); tests/studies/check_study.py checks the CSV's rows, the plot, and
# that the errors fall as stated, at the observed orders stated there.
# Usage: accuracy_small.sh KNITFLOW OUTDIR CASE
set -euo pipefail
exe=$1 out=$2 case=$3
root="$(cd "$(dirname "$0")/../.." && pwd)"
rm -rf "$out"
/usr/bin/python3 "$root/jobs/studies/accuracy.py" --exe "$exe" --out "$out" --case "$case" \
  | tee "$out.log"
/usr/bin/python3 "$root/tests/studies/check_study.py" "$case" "$out"
