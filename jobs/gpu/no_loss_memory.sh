#!/usr/bin/env bash
# One-rank time and memory of two knitflow binaries, alternated in one call on one GPU (after
# `. .devrt/prelude.sh`, from the project root): the DualSPHysics column's first STEPS steps
# (default 5,000), the 4M dam break ("verlet" lists, 2,000 steps) and the pour's whole run, each
# with its "done", diagnostics and memory lines (the backend's peak is what list work changes).
# Usage: jobs/gpu/no_loss_memory.sh BEFORE AFTER [ROUNDS] [STEPS]
set -uo pipefail
before=$1 after=$2 rounds=${3:-2} steps=${4:-5000}
off="--set output.enabled=false"
verlet="--set solver.neighbour_list=\"verlet\""
keep() { grep -E '^(done|particles|memory)' | sed "s/^/$1: /"; }
for r in $(seq "$rounds"); do
  for which in before after; do
    exe=${!which}
    echo "== $which ($exe), round $r"
    "$exe" run scenes/dambreak.toml --device cuda $off $verlet --set fluid.spacing=0.0015874 \
      --set solver.max_steps=2000 2>&1 | keep "dambreak 4M"
    "$exe" run scenes/bench/dambreak_column.toml --device cuda $off $verlet \
      --set solver.max_steps="$steps" 2>&1 | keep "column $steps"
    "$exe" run scenes/pour.toml --device cuda $off $verlet 2>&1 | keep pour
  done
done
