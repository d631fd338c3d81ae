#!/usr/bin/env bash
# The fluid's options on the GPU (particle shifting, the artificial viscosity), after
# `. .devrt/prelude.sh`, from the project root: their tests (test_shifting_K,
# test_artificial_viscosity_K, test_backends' CPU-against-GPU cases, found on PATH), memcheck on
# their kernels' tests, and their cost: the dam break at 4M fluid ("verlet" lists) without them
# and with each, a step at steady state (runs of 300 and 1,500 steps), BEFORE (a build without
# them: no loss) against AFTER, twice, alternating; the whole pour (neither) for both.
#
#   jobs/gpu/fluid_options_checks.sh BEFORE AFTER OUTDIR
set -uo pipefail
before=$1 after=$2 out=$3
mkdir -p "$out"
echo "== tests ($(date -u +%T))"
for t in test_shifting_K test_artificial_viscosity_K; do
  $t 2>&1 | grep -E "OK|FAILED|PASSED|SKIPPED" | tail -8
done
test_backends 2>&1 | grep -E "^\[ +(OK|FAILED)|Shifting|PASSED" | tail -30
echo "== memcheck"
for t in test_shifting_K test_artificial_viscosity_K; do
  /usr/local/cuda/bin/compute-sanitizer --tool memcheck $t --gtest_filter='*Cuda*' 2>&1 | tail -2
done
dp=$(python3 -c "print('%.8g' % ((0.016 / 4e6) ** (1 / 3)))")
step() { # EXE [--set ...]: the done lines of runs of 300 and 1,500 steps
  local exe=$1
  shift
  for s in 300 1500; do
    "$exe" run scenes/dambreak.toml --device cuda --set 'solver.neighbour_list="verlet"' \
      --set "fluid.spacing=$dp" --set output.enabled=false --output "$out/o" \
      --set "solver.max_steps=$s" "$@" 2>&1 | grep '^done' | sed "s/^/    $s: /"
  done
}
echo "== dam break 4M, verlet ($(date -u +%T))"
for round in 1 2; do
  for which in before after; do
    echo "-- $which"
    step "${!which}"
  done
  echo "-- after, shifting"
  step "$after" --set 'solver.shifting="fickian"'
  echo "-- after, artificial viscosity 0.01"
  step "$after" --set fluid.artificial_viscosity=0.01
done
echo "-- after, shifting, kernel times"
KF_KERNEL_TIMES=1 "$after" run scenes/dambreak.toml --device cuda --set 'solver.neighbour_list="verlet"' \
  --set "fluid.spacing=$dp" --set output.enabled=false --output "$out/o" --set solver.max_steps=1500 \
  --set 'solver.shifting="fickian"' 2>&1 | sed -n '/^kernel times/,/^host waits/p' | head -14
echo "== the pour, whole ($(date -u +%T))"
for which in before after; do
  echo "-- $which: $("${!which}" run scenes/pour.toml --device cuda --set output.enabled=false \
    --output "$out/o" 2>&1 | grep '^done')"
done
rm -rf "$out/o"
