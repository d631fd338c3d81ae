#!/usr/bin/env bash
# P10's checks of a change on one GPU, with two knitflow binaries (after `. .devrt/prelude.sh`,
# from the project root): the GPU tests the issue names (those packed: CPU against GPU, the
# coupling, absorption, self-contact and the knit's one force pass), compute-sanitizer memcheck on
# the small pour (dp 0.012 m, 24 x 24 stitches, 1,500 steps) in both capillary models with AFTER,
# and the conserving pour's whole run with each binary (its end-of-run diagnostics beside).
#
#   jobs/gpu/p10_checks.sh BEFORE AFTER     # logs in $OUT/p10_checks (default out/p10_checks)
set -uo pipefail
before=$1 after=$2
out=${OUT:-out}/p10_checks
mkdir -p "$out"
off="--set output.enabled=false"
for t in test_backends test_coupling_K test_absorption_K test_self_contact_K test_knit_forces_K \
  test_neighbour_grid_K test_exec_K; do
  command -v "$t" >/dev/null || continue
  "$t" >"$out/$t.log" 2>&1
  echo "$t rc=$? $(grep -E '^\[  (PASSED|FAILED)' "$out/$t.log" | tr '\n' ' ')"
done
san=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -1)
if [ -n "$san" ]; then
  for model in paper conserving; do
    "$san" --tool memcheck --error-exitcode 9 "$after" run scenes/pour.toml --device cuda $off \
      --output "$out/o" --set fluid.spacing=0.012 --set knit.piece.0.wales=24 \
      --set knit.piece.0.courses=24 --set solver.max_steps=1500 \
      --set "capillary.model=\"$model\"" >"$out/memcheck_$model.log" 2>&1
    echo "memcheck ($model) rc=$? $(grep -E 'SUMMARY' "$out/memcheck_$model.log")" \
      "$(grep -E '^coupling:' "$out/memcheck_$model.log")"
  done
fi
for which in before after; do
  "${!which}" run scenes/pour.toml --device cuda $off --output "$out/o" \
    --set 'capillary.model="conserving"' >"$out/conserving_$which.log" 2>&1
  echo "$which conserving pour: $(grep -E '^done' "$out/conserving_$which.log")"
  grep -E '^(particles|outflow|coupling):' "$out/conserving_$which.log" | sed 's/^/    /'
done
rm -rf "$out/o"
