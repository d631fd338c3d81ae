#!/usr/bin/env bash
# The coupled pour split on one GPU, two builds side by side (after `. .devrt/prelude.sh`, from
# the project root; 2 ranks sharing GPU 0 over MPI): test_distributed_knit_mpi's coupled GPU case
# on 2 ranks; the paper's pour (its stream as written, STEPS steps) and the pour with its stream
# started at the knit (3,000 steps: coupled from the start), OLD and NEW alternated ROUNDS times,
# each run's done line and its coupling line (the lists' builds); the latter on one rank with NEW.
# Logs in OUTDIR. What the coupling's lists kept over steps on N ranks (77f02e2), the owned
# forces rows (cac0489) and the pairs' weight (c336707) do on a GPU.
# Usage: jobs/gpu/p5_coupled_share.sh OLD NEW OUTDIR [STEPS] [ROUNDS]
set -uo pipefail
old=$1 new=$2 out=$3 steps=${4:-8000} rounds=${5:-2}
mkdir -p "$out"
export PATH="$PATH:build/cuda/tests"
/usr/bin/time -f "wall %e s" mpirun -n 2 --oversubscribe test_distributed_knit_mpi \
  --gtest_filter='*OnTheGpuTheCoupled*' >"$out/coupled_test.log" 2>&1
tail -4 "$out/coupled_test.log"
off=(--device cuda --profile --set output.enabled=false)
contact=(--set "fluid.block.0.min=[-0.04,-0.04,0.535]" --set "fluid.block.0.max=[0.04,0.04,1.785]")
show() { echo "$1: $(grep -E '^done' "$2")"; grep -E '^(coupling|ranks):' "$2" | sed 's/^/    /'; }
for r in $(seq "$rounds"); do
  for which in old new; do
    exe=${!which}
    mpirun -n 2 --oversubscribe "$exe" run scenes/pour.toml "${off[@]}" \
      --set solver.max_steps="$steps" >"$out/pour2_${which}_$r.log" 2>&1
    show "pour, 2 ranks, $which, round $r" "$out/pour2_${which}_$r.log"
    mpirun -n 2 --oversubscribe "$exe" run scenes/pour.toml "${off[@]}" "${contact[@]}" \
      --set solver.max_steps=3000 >"$out/contact2_${which}_$r.log" 2>&1
    show "pour at the knit, 2 ranks, $which, round $r" "$out/contact2_${which}_$r.log"
  done
done
"$new" run scenes/pour.toml "${off[@]}" "${contact[@]}" --set solver.max_steps=3000 \
  >"$out/contact1_new.log" 2>&1
show "pour at the knit, 1 rank, new" "$out/contact1_new.log"
