#!/usr/bin/env bash
# P7's full studies on a GPU machine (after `. .devrt/prelude.sh`, from the project root): the
# AXES of each CASE at the full sizes on the GPU (jobs/studies/accuracy.py --full --device
# cuda). CASES: a case, several joined by commas, or all; AXES: all (default: every axis, the
# CASE_all.csv and the Pareto plot), an axis, or several joined by commas. The runs' snapshots
# stay in a scratch directory; the CSVs, plots and logs go to OUTDIR/studies.tar (one file: a
# device call brings back few), brought up to date after each axis's study and when the job is
# stopped (`timeout`, a signal): a call cut short keeps the axes it finished (accuracy.py
# writes a CSV an axis). A second call with the same OUTDIR adds to the tar.
# Usage: jobs/gpu/p7_studies.sh KNITFLOW OUTDIR [CASES] [AXES]
set -uo pipefail
exe=$1 out=$2 cases=${3:-all} axes=${4:-all}
# The CSVs' commit is the packed binaries' (scripts/pack-gpu.sh), not this copy's git history.
root="$(cd "$(dirname "$0")/../.." && pwd)"
[ -z "${KF_COMMIT:-}" ] && [ -f "$root/.devrt/commit" ] && export KF_COMMIT="$(cat "$root/.devrt/commit")"
[ "$cases" = all ] && cases=hydrostatic,dambreak,catenary,wicking,drape,pour
work=$(mktemp -d)
mkdir -p "$out/studies"
[ -f "$out/studies.tar" ] && tar xf "$out/studies.tar" -C "$out"
save() {
  cp "$work"/*.csv "$work"/*.png "$out/studies/" 2>/dev/null
  tar cf "$out/studies.tar.part" -C "$out" studies && mv "$out/studies.tar.part" "$out/studies.tar"
}
stopped() {
  echo "p7_studies: stopped; the finished axes saved in $out/studies.tar" >&2
  save
  rm -rf "$out/studies" "$work"
  exit 143
}
trap stopped TERM INT
for case in ${cases//,/ }; do
  for axis in ${axes//,/ }; do
    python3 jobs/studies/accuracy.py --full --device cuda --exe "$exe" --case "$case" \
      --axis "$axis" --out "$work" 2>&1 | tee "$out/studies/${case}_${axis}_full.log"
    save
    rm -rf "$work"/"${case}"_*/
  done
done
rm -rf "$out/studies" "$work"
