#!/usr/bin/env bash
# P5, what a rank's host holds at set-up: the 8M dam break ("verlet") on 1, 2 and 4 ranks sharing
# one GPU, a few steps, each rank's resident peak (/usr/bin/time) and the summary's memory line
# (the backend's most a rank, the host's resident peak), with the wall time of set-up and steps.
# After `. .devrt/prelude.sh`, from the project root.
# Usage: jobs/gpu/p5_host_setup.sh KNITFLOW [STEPS]
set -uo pipefail
exe=$1 steps=${2:-20}
for n in 1 2 4; do
  echo "== 8M dam break, $n rank(s) sharing the GPU, $steps steps"
  start=$(date +%s.%N)
  mpirun -n "$n" --oversubscribe /usr/bin/time -f "rank peak resident %M kB" "$exe" run \
    scenes/dambreak.toml --device cuda --set output.enabled=false --set fluid.spacing=0.00125 \
    --set solver.neighbour_list=\"verlet\" --set solver.max_steps="$steps" 2>&1 |
    grep -E '^(done|particles|memory|rank peak)'
  echo "wall (set-up and steps, mpirun included): $(awk "BEGIN{print $(date +%s.%N) - $start}") s"
done
