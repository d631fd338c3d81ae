#!/usr/bin/env bash
# P7's full studies on a GPU machine (after `. .devrt/prelude.sh`, from the project root): every
# axis of CASE (hydrostatic, dambreak or all) at the full resolutions on the GPU
# (jobs/studies/accuracy.py --full --device cuda); the runs' snapshots stay in a scratch
# directory, the CSVs, plots and log go to OUTDIR/studies.tar (one file: a device call brings
# back few). AXIS: all (default) or one axis.
# Usage: jobs/gpu/p7_studies.sh KNITFLOW OUTDIR [CASE] [AXIS]
set -uo pipefail
exe=$1 out=$2 case=${3:-all} axis=${4:-all}
work=$(mktemp -d)
mkdir -p "$out/studies"
python3 jobs/studies/accuracy.py --full --device cuda --exe "$exe" --case "$case" --axis "$axis" \
  --out "$work" 2>&1 | tee "$out/studies/${case}_${axis}_full.log"
cp "$work"/*.csv "$work"/*.png "$out/studies/" 2>/dev/null
tar cf "$out/studies.tar" -C "$out" studies && rm -rf "$out/studies"
rm -rf "$work"
