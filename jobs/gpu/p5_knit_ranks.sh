#!/usr/bin/env bash
# The knit on the GPU on N ranks, after `. .devrt/prelude.sh`, from the project root: the paper's
# pour (64,000 fluid + 49,923 knit, "verlet" lists) and drape (49,923 knit, self-collision) on 1
# rank, on 2 and 4 ranks sharing GPU 0 (MPI transport through page-locked host memory), and on 2
# ranks with a GPU each where the host has two (NCCL); output off, profiled.
# Usage: jobs/gpu/p5_knit_ranks.sh KNITFLOW [STEPS]   (prints each run's done/split lines)
set -uo pipefail
exe=$1 steps=${2:-300}
gpus=$(nvidia-smi -L | wc -l)
run() { # scene ranks devices label
  echo "== $4: $1, $2 rank(s), CUDA_VISIBLE_DEVICES=$3"
  CUDA_VISIBLE_DEVICES=$3 mpirun -n "$2" --oversubscribe "$exe" run "scenes/$1.toml" \
    --device cuda --profile --set output.enabled=false --set solver.max_steps="$steps" 2>&1 |
    grep -E '^(done|split|knitflow|  [a-z])' | grep -v '^  *$'
}
for scene in pour drape; do
  run $scene 1 0 "one GPU"
  run $scene 2 0 "ranks sharing one GPU"
  run $scene 4 0 "ranks sharing one GPU"
  [ "$gpus" -ge 2 ] && run $scene 2 0,1 "a GPU a rank"
done
