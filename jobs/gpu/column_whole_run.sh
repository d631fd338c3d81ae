#!/usr/bin/env bash
# The P4 column goal's measure: DualSPHysics's whole dam break with a column (1.5 s, dp 3.5 mm,
# continuity density, "verlet" lists), run once by each knitflow binary given, one after the
# other on the same GPU (two machines of one kind differ by up to 1%: compare within a call).
# For each: the wall time, steps, ms a step against DualSPHysics's 8.3, why lists ended, and
# the GPU time of the heaviest kernels. After `. .devrt/prelude.sh`, from the project root:
#
#   jobs/gpu/column_whole_run.sh knitflow knitflow_old       # logs in $OUT (default out/column)
#
# COLUMN_KERNEL_TIMES=0 runs without the per-kernel timing (two events around every launch),
# as a user would: the goal's figure; the default (1) adds the table of kernels.
set -uo pipefail
out=${OUT:-out/column}
mkdir -p "$out"
export PATH="$PATH:build/cuda/apps"
[ $# -gt 0 ] || set -- knitflow
for exe in "$@"; do
  log="$out/whole_$(basename "$exe").log"
  KF_KERNEL_TIMES=${COLUMN_KERNEL_TIMES:-1} timeout "${COLUMN_TIMEOUT:-280}" "$exe" run scenes/bench/dambreak_column.toml \
    --device cuda --set output.enabled=false --set 'solver.neighbour_list="verlet"' > "$log" 2>&1
  rc=$?
  echo "== $exe (rc $rc)"
  # "done: N steps to t = 1.5 s in W s wall, ..."
  awk '/^done:/ { steps = $2; for (i = 1; i <= NF; ++i) if ($i == "wall,") wall = $(i - 2);
                  printf "%s steps, %s s: %.3f ms a step, %.2fx DualSPHysics (8.3 ms)\n",
                         steps, wall, 1000 * wall / steps, 8.3 / (1000 * wall / steps) }' "$log"
  grep -E '^neighbour lists:|GPU busy' "$log"
  grep -A6 -E '^  label +launches' "$log"
done
