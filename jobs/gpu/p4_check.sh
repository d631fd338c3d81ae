#!/usr/bin/env bash
# P4 on a GPU machine, one command (after `. .devrt/prelude.sh`, from the project root): every
# GPU test (jobs/gpu/gpu_tests.sh, the CPU/GPU comparison among them), compute-sanitizer
# memcheck and racecheck on a small scene, the P4 benchmark table (bench_gpu), the whole pour,
# and GPU time per kernel.
# Logs, CSV and the table go to $OUT (default out/p4). Binaries are found on PATH
# (.devrt/bin from scripts/pack-gpu.sh) or in build/cuda.
set -uo pipefail
out=${OUT:-out/p4}
mkdir -p "$out"
export PATH="$PATH:build/cuda/apps:build/cuda/bench:build/cuda/tests"
nvidia-smi --query-gpu=name,memory.total,clocks.max.sm,clocks.max.mem --format=csv > "$out/gpu.txt" 2>&1
# Every test program with GPU cases (CPU/GPU comparison included): one line each, logs in
# $out/gpu_tests; pack them with `jobs/gpu/gpu_tests.sh --list` (see that script).
OUT="$out/gpu_tests" "$(dirname "$0")/gpu_tests.sh"
echo "gpu_tests rc=$?"
san=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -1)
if [ -n "$san" ]; then
  for tool in memcheck racecheck; do
    "$san" --tool $tool --error-exitcode 9 knitflow run scenes/pour.toml --device cuda \
      --set output.enabled=false --set fluid.spacing=0.012 --set knit.piece.0.wales=24 \
      --set knit.piece.0.courses=24 --set solver.max_steps=${P4_SAN_STEPS:-10} > "$out/sanitizer_$tool.log" 2>&1
    echo "compute-sanitizer $tool rc=$? $(grep -E 'SUMMARY' "$out/sanitizer_$tool.log")"
  done
fi
bench_gpu --device cuda --csv "$out/bench_gpu.csv" > "$out/bench_gpu.log" 2>&1
echo "bench_gpu rc=$?"
# The column when the surge reaches it (t = 0.3 s): lists are rebuilt there, unlike at rest.
bench_gpu --device cuda --cases column --column-dp 0.0035 --column-start 0.3 --max-seconds 8 \
  --csv "$out/bench_column_surge.csv" > "$out/bench_column_surge.log" 2>&1
echo "column surge rc=$?"
# The column with the paper's summation density (the scene integrates it, as DualSPHysics).
bench_gpu --device cuda --cases column --column-dp 0.0035 --lists verlet \
  --set 'solver.density="summation"' --csv "$out/bench_column_summation.csv" \
  > "$out/bench_column_summation.log" 2>&1
echo "column summation rc=$?"
# DualSPHysics's figure is a mean over its whole run (1.5 s, ~48k steps, 4 minutes here): opt in.
if [ "${P4_WHOLE_COLUMN:-0}" = 1 ]; then
  KF_KERNEL_TIMES=1 knitflow run scenes/bench/dambreak_column.toml --device cuda \
    --set output.enabled=false --set 'solver.neighbour_list="verlet"' > "$out/column_whole.log" 2>&1
  echo "column whole run rc=$? $(grep -E '^done' "$out/column_whole.log")"
fi
knitflow run scenes/pour.toml --device cuda --set output.enabled=false > "$out/pour_whole.log" 2>&1
echo "pour rc=$? $(grep -E '^done' "$out/pour_whole.log")"
# GPU time per kernel (KF_KERNEL_TIMES=1): the first 300 steps and the whole pour.
KF_KERNEL_TIMES=1 knitflow run scenes/pour.toml --device cuda --set output.enabled=false \
  --set solver.max_steps=300 > "$out/kernel_times_pour300.log" 2>&1
KF_KERNEL_TIMES=1 knitflow run scenes/pour.toml --device cuda --set output.enabled=false \
  > "$out/kernel_times_pour.log" 2>&1
echo "kernel times rc=$? $(grep -E '^kernel times' "$out/kernel_times_pour.log")"
