#!/usr/bin/env bash
# P5's overlap measured (after `. .devrt/prelude.sh`, from the project root, on a host with two
# GPUs): the 4M dam break, "verlet" lists, on 1 rank and on 2 (one rank a GPU, NCCL), strong
# (4M in all) and weak (4M a rank), with [parallel] overlap on and off, ROUNDS times alternating.
# Usage: jobs/gpu/p5_overlap.sh KNITFLOW [STEPS] [ROUNDS]   (prints each run's done/split lines)
set -uo pipefail
exe=$1 steps=${2:-300} rounds=${3:-2}
run() { # ranks spacing overlap label
  echo "== $4: $1 rank(s), spacing $2, overlap $3"
  mpirun -n "$1" "$exe" run scenes/dambreak.toml --device cuda --profile \
    --set output.enabled=false --set fluid.spacing="$2" --set solver.neighbour_list=\"verlet\" \
    --set parallel.overlap="$3" --set solver.max_steps="$steps" 2>&1 |
    grep -E '^(done|split)' | grep -v '^  *$'
}
for r in $(seq "$rounds"); do
  run 1 0.0015874 true "one GPU 4M"
  for o in true false; do
    run 2 0.0015874 $o "strong 4M"
    run 2 0.0012599 $o "weak 4M a rank"
  done
done
