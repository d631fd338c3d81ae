#!/usr/bin/env bash
# P10's figures with one knitflow binary on the GPU at hand (after `. .devrt/prelude.sh`, from the
# project root): the whole pour (ROUNDS times), the drape's whole run twice, the pour's first 300
# steps twice, each with its end-of-run diagnostics; the pour's and the drape's GPU time per
# kernel; then jobs/gpu/p10_checks.sh (the GPU tests P10 names, compute-sanitizer on the small
# pour, the conserving pour's whole run twice). Logs in $OUT/p10_figures (default out/p10_figures).
#
#   jobs/gpu/p10_figures.sh KNITFLOW [ROUNDS]
set -uo pipefail
exe=$1 rounds=${2:-3}
out=${OUT:-out}/p10_figures
mkdir -p "$out"
off="--set output.enabled=false"
run() { # LABEL LOG SCENE [ARGS...]
  local label=$1 log=$2 scene=$3
  shift 3
  "$exe" run "$scene" --device cuda $off --output "$out/o" "$@" >"$log" 2>&1
  echo "$label: $(grep -E '^done' "$log" | sed 's/^done: //')"
  grep -E '^(particles|knit|coupling|outflow):' "$log" | sed 's/^/    /'
}
nvidia-smi --query-gpu=name,memory.total,clocks.max.sm --format=csv,noheader
for r in $(seq "$rounds"); do
  run "pour $r" "$out/pour_$r.log" scenes/pour.toml
done
for r in 1 2; do
  run "drape $r" "$out/drape_$r.log" scenes/drape.toml
  run "pour, first 300 steps, $r" "$out/pour300_$r.log" scenes/pour.toml \
    --set solver.max_steps=300
done
rm -rf "$out/o"
bash jobs/gpu/knit_kernel_times.sh "$exe" "$out"
# The GPU tests, memcheck and the conserving pour twice (p10_checks' "before" and "after").
OUT=$out bash jobs/gpu/p10_checks.sh "$exe" "$exe"
