#!/usr/bin/env bash
# P5's "no loss on one rank": the same runs with two knitflow binaries in one call, alternating,
# on one GPU (after `. .devrt/prelude.sh`, from the project root): the DualSPHysics column's
# whole run, the 4M dam break ("verlet" lists, 2,000 steps) and the pour (first 300 steps).
# Usage: jobs/gpu/p5_no_loss.sh BEFORE AFTER [ROUNDS]   (prints each run's "done" line)
set -uo pipefail
before=$1 after=$2 rounds=${3:-1}
off="--set output.enabled=false"
verlet="--set solver.neighbour_list=\"verlet\""
for r in $(seq "$rounds"); do
  for which in before after; do
    exe=${!which}
    echo "== $which ($exe), round $r"
    "$exe" run scenes/bench/dambreak_column.toml --device cuda $off $verlet 2>&1 |
      grep -E '^done' | sed 's/^/column: /'
    "$exe" run scenes/dambreak.toml --device cuda $off $verlet --set fluid.spacing=0.0015874 \
      --set solver.max_steps=2000 2>&1 | grep -E '^done' | sed 's/^/dambreak 4M: /'
    "$exe" run scenes/pour.toml --device cuda $off $verlet --set solver.max_steps=300 2>&1 |
      grep -E '^done' | sed 's/^/pour 300: /'
  done
done
