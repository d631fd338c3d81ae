#!/usr/bin/env bash
# P5's NCCL path and P9's first points on a host with two GPUs (one rank a GPU), after
# `. .devrt/prelude.sh`, from the project root: the 4M dam break on 1 and 2 ranks (strong), 4M a
# rank on 2 (weak), NCCL (auto) and MPI through page-locked host memory, lists off and "verlet";
# output off, profiled.
# Usage: jobs/gpu/p5_two_gpus.sh KNITFLOW [STEPS]   (prints each run's done/split lines)
set -uo pipefail
exe=$1 steps=${2:-300}
run() { # ranks spacing lists transport label
  echo "== $5: $1 rank(s), spacing $2, lists $3, transport $4"
  mpirun -n "$1" "$exe" run scenes/dambreak.toml --device cuda --profile \
    --set output.enabled=false --set fluid.spacing="$2" --set solver.neighbour_list=\""$3"\" \
    --set parallel.transport=\""$4"\" --set solver.max_steps="$steps" 2>&1 |
    grep -E '^(done|split|neighbour|  [a-z])' | grep -v '^  *$'
}
for lists in off verlet; do
  run 1 0.0015874 $lists auto "strong 4M"
  run 2 0.0015874 $lists auto "strong 4M"
  run 2 0.0015874 $lists mpi "strong 4M"
  run 2 0.0012599 $lists auto "weak 4M a rank"
done
