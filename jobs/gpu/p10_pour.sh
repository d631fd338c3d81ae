#!/usr/bin/env bash
# P10's measure: the paper's pour over its whole 1.5 s and the drape over its whole run, with two
# knitflow binaries in one call, alternating (two machines of one kind differ by up to 1%), each
# run's wall time and its end-of-run diagnostics (a change that keeps the arithmetic keeps them to
# the digit); then P5's no-loss runs (column, 4M dam break, the pour's first 300 steps) and the
# pour's GPU time per kernel with AFTER. After `. .devrt/prelude.sh`, from the project root:
#
#   jobs/gpu/p10_pour.sh BEFORE AFTER [ROUNDS]     # logs in $OUT/p10 (default out/p10)
set -uo pipefail
before=$1 after=$2 rounds=${3:-2}
out=${OUT:-out}/p10
mkdir -p "$out"
off="--set output.enabled=false"
run() { # WHICH EXE SCENE LOG
  /usr/bin/time -f "wall %e s" "$2" run "$3" --device cuda $off --output "$out/o" >"$4" 2>&1
  echo "$1 $(basename "$3"): $(grep -E '^done' "$4" | sed 's/^done: //')"
  grep -E '^(particles|knit|coupling|outflow):' "$4" | sed 's/^/    /'
}
for r in $(seq "$rounds"); do
  for which in before after; do
    run "$which" "${!which}" scenes/pour.toml "$out/pour_${which}_$r.log"
  done
done
for which in before after; do
  run "$which" "${!which}" scenes/drape.toml "$out/drape_${which}.log"
done
bash jobs/gpu/p5_no_loss.sh "$before" "$after" 1
rm -rf "$out/o"
bash jobs/gpu/knit_kernel_times.sh "$after" "$out"
