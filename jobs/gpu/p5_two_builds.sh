#!/usr/bin/env bash
# Two builds side by side on a host with two GPUs (after `. .devrt/prelude.sh`, from the project
# root): the 4M dam break ("verlet" lists, 300 steps, output off) on one GPU, on 2 GPUs strong
# (4M in all) and weak (4M a rank), one rank a GPU (NCCL), and the paper's pour on 1 and 2 GPUs,
# alternating OLD and NEW ROUNDS times.
# Usage: jobs/gpu/p5_two_builds.sh OLD NEW [STEPS] [ROUNDS]   (prints each run's done line)
set -uo pipefail
old=$1 new=$2 steps=${3:-300} rounds=${4:-2}
run() { # exe ranks scene spacing label
  local sp=()
  [ -n "$4" ] && sp=(--set fluid.spacing="$4" --set solver.neighbour_list=\"verlet\")
  printf '%-34s %-4s ' "$5, $2 rank(s)" "$(basename "$(dirname "$1")")"
  mpirun -n "$2" "$1" run "scenes/$3.toml" --device cuda --set output.enabled=false \
    "${sp[@]}" --set solver.max_steps="$steps" 2>&1 | grep -E '^done' | sed 's/^done: //'
}
for r in $(seq "$rounds"); do
  for exe in "$old" "$new"; do
    run "$exe" 1 dambreak 0.0015874 "dam break 4M"
    run "$exe" 2 dambreak 0.0015874 "dam break 4M, strong"
    run "$exe" 2 dambreak 0.0012599 "dam break 8M, weak"
    run "$exe" 1 pour "" "pour"
    run "$exe" 2 pour "" "pour"
  done
done
