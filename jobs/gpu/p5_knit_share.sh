#!/usr/bin/env bash
# What a rank holds of a large knit, and what the knit's choices of ghosts cost, two builds side
# by side (after `. .devrt/prelude.sh`, from the project root; ranks share GPU 0 through MPS):
# - the drape scaled up to W x W stitches at the paper's stitch size (W = 1024: 3.16M points; the
#   piece and the room grown with it), set-up and one step on 1, 2 and 4 ranks: each rank's wall,
#   the backend's most a rank held, the host's resident peak;
# - the paper's pour on 2 ranks, STEPS steps, alternated ROUNDS times: the wall and the knit's
#   ghost choices (`--profile`).
# Usage: jobs/gpu/p5_knit_share.sh OLD NEW [W] [STEPS] [ROUNDS]
set -uo pipefail
old=$1 new=$2 w=${3:-1024} steps=${4:-3000} rounds=${5:-2}
size=$(python3 -c "print(0.7 * $w / 128)")
half=$(python3 -c "print(0.35 * $w / 128 + 0.1)")
big=(run scenes/drape.toml --device cuda --set output.enabled=false --set solver.max_steps=1
  --set knit.piece.0.wales="$w" --set knit.piece.0.courses="$w" --set knit.piece.0.width="$size"
  --set knit.piece.0.height="$size" --set "domain.min=[-$half,-$half,0]"
  --set "domain.max=[$half,$half,1]")
for ranks in 1 2 4; do
  for exe in "$old" "$new"; do
    echo "== drape $w x $w, $ranks rank(s): $exe"
    /usr/bin/time -f "wall %e s" mpirun -n "$ranks" --oversubscribe "$exe" "${big[@]}" 2>&1 |
      grep -E '^(done|memory|knit:|wall)'
  done
done
for r in $(seq "$rounds"); do
  for exe in "$old" "$new"; do
    echo "== pour, 2 ranks, $steps steps, round $r: $exe"
    mpirun -n 2 --oversubscribe "$exe" run scenes/pour.toml --device cuda --profile \
      --set output.enabled=false --set solver.max_steps="$steps" 2>&1 |
      grep -E '^(done|memory|split)|chosen anew|^knit:'
  done
done
