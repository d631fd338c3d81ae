#!/usr/bin/env bash
# P5's "overhead of the split on one GPU": the dam break on 1, 2 and 4 ranks sharing one GPU
# (MPI transport, rows packed on the device and staged through the host), after
# `. .devrt/prelude.sh`, from the project root. Strong: 4M particles in all; weak: 4M a rank.
# Neighbour lists LISTS ("off", or "verlet": ghosts kept between sorts), output off, profiled.
# Usage: jobs/gpu/p5_ranks_share.sh KNITFLOW [STEPS] [LISTS]
#   (prints each run's done/split/stage lines)
set -uo pipefail
exe=$1 steps=${2:-300} lists=${3:-off}
run() { # ranks spacing label
  echo "== $3: $1 rank(s), spacing $2, lists $lists"
  mpirun -n "$1" --oversubscribe "$exe" run scenes/dambreak.toml --device cuda --profile \
    --set output.enabled=false --set fluid.spacing="$2" \
    --set solver.neighbour_list=\""$lists"\" \
    --set solver.max_steps="$steps" 2>&1 |
    grep -E '^(done|split|particles|neighbour|  [a-z])' | grep -v '^  *$'
}
for n in 1 2 4; do run $n 0.0015874 "strong 4M"; done
run 2 0.0012599 "weak 4M a rank"
run 4 0.0010000 "weak 4M a rank"
