#!/usr/bin/env bash
# P7's full studies on a GPU machine (after `. .devrt/prelude.sh`, from the project root): every
# axis of each CASE (a case, several joined by commas, or all) at the full sizes on the GPU
# (jobs/studies/accuracy.py --full --device cuda); the runs' snapshots stay in a scratch
# directory, the CSVs, plots and logs go to OUTDIR/studies.tar (one file: a device call brings
# back few), brought up to date after each case (a call cut short keeps the cases it finished).
# AXIS: all (default) or one axis.
# Usage: jobs/gpu/p7_studies.sh KNITFLOW OUTDIR [CASE] [AXIS]
set -uo pipefail
exe=$1 out=$2 cases=${3:-all} axis=${4:-all}
[ "$cases" = all ] && cases=hydrostatic,dambreak,catenary,wicking,drape,pour
work=$(mktemp -d)
mkdir -p "$out/studies"
for case in ${cases//,/ }; do
  python3 jobs/studies/accuracy.py --full --device cuda --exe "$exe" --case "$case" \
    --axis "$axis" --out "$work" 2>&1 | tee "$out/studies/${case}_${axis}_full.log"
  cp "$work"/*.csv "$work"/*.png "$out/studies/" 2>/dev/null
  tar cf "$out/studies.tar.part" -C "$out" studies && mv "$out/studies.tar.part" "$out/studies.tar"
  rm -rf "$work"/"${case}"_*/
done
rm -rf "$out/studies" "$work"
