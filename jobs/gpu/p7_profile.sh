#!/usr/bin/env bash
# Where the knit's study runs spend their time on a GPU (P7's cost model): each run once with
# --profile (every stage's time, the device synchronised) and once with KF_KERNEL_TIMES=1 (each
# kernel's GPU time), logs under OUTDIR/profile/.
# Usage: jobs/gpu/p7_profile.sh KNITFLOW OUTDIR
set -uo pipefail
exe=$1 out=$2/profile
mkdir -p "$out"
y=knit.yarn_samples=0
run() { # NAME SCENE SETS...
  local name=$1 scene=$2; shift 2
  local sets=(); for s in "$@"; do sets+=(--set "$s"); done
  timeout 120 "$exe" run "$scene" --device cuda "${sets[@]}" --set output.enabled=false \
    --output "$out/$name.o" >"$out/$name.wall.log" 2>&1
  timeout 120 "$exe" run "$scene" --device cuda "${sets[@]}" --set output.enabled=false \
    --output "$out/$name.o" --profile >"$out/$name.profile.log" 2>&1
  KF_KERNEL_TIMES=1 timeout 120 "$exe" run "$scene" --device cuda "${sets[@]}" \
    --set output.enabled=false --output "$out/$name.o" >"$out/$name.kernels.log" 2>&1
  rm -rf "$out/$name.o"
}
w="simulation.end_time=0.3 $y"
run wick32 scenes/wicking.toml $w knit.piece.0.courses=32 knit.piece.0.wales=4
run wick64 scenes/wicking.toml $w knit.piece.0.courses=64 knit.piece.0.wales=8
run wick128 scenes/wicking.toml $w knit.piece.0.courses=128 knit.piece.0.wales=16
run wick64s1 scenes/wicking.toml $w knit.substeps=1
run wick64s8 scenes/wicking.toml $w knit.substeps=8
p="simulation.end_time=0.15 $y"
run pour128 scenes/pour.toml $p knit.piece.0.wales=128 knit.piece.0.courses=128
run pour256 scenes/pour.toml $p knit.piece.0.wales=256 knit.piece.0.courses=256
run pour128s1 scenes/pour.toml $p knit.piece.0.wales=128 knit.piece.0.courses=128 knit.substeps=1
run pour128s8 scenes/pour.toml $p knit.piece.0.wales=128 knit.piece.0.courses=128 knit.substeps=8
run pour128f01 scenes/pour.toml $p knit.piece.0.wales=128 knit.piece.0.courses=128 fluid.spacing=0.01
run pour128cons scenes/pour.toml $p knit.piece.0.wales=128 knit.piece.0.courses=128 capillary.model=conserving
tar cf "$2/profile.tar" -C "$2" profile && rm -rf "$out"
