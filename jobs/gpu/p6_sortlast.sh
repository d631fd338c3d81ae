#!/usr/bin/env bash
# P6's sort-last compositing on a GPU machine (after `. .devrt/prelude.sh`, from the project
# root): the paper's pour to POUR_END on the GPU, its last 5 frames at 1920 x 1080 with every
# effect on, drawn whole by one rank and in 2 and 4 parts by ranks sharing GPU 0 (the opaque
# scene composited by depth, the volumetric yarns by "over" in the parts' order); each frame's
# time split printed, the last frame's pictures left in OUTDIR/sortlast (compared on the CPU
# machine: jobs/gpu/compare_pictures.py).
# Usage: jobs/gpu/p6_sortlast.sh KNITFLOW OUTDIR [POUR_END]   (POUR_END: default 0.6 s)
set -uo pipefail
exe=$1 out=$2 end=${3:-0.6} dev=${DEVICE:-cuda}
mkdir -p "$out/sortlast"
work=$(mktemp -d)
echo "== pour on the GPU to t = $end s, a snapshot every 0.02 s"
"$exe" run scenes/pour.toml --device "$dev" --quiet --set simulation.end_time="$end" \
  --set output.interval=0.02 --output "$work/pour" | tail -2
last=$(ls "$work/pour"/frame_*.h5 | tail -1 | sed -E 's/.*frame_0*([0-9]+)\.h5/\1/')
frames="$((last - 4)):$last:1"
echo "== frames $frames whole on one rank"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "$frames" \
  --out "$work/c1" | grep frame_
cp "$work/c1/frame_$(printf %06d "$last").png" "$out/sortlast/whole.png"
for n in 2 4; do
  echo "== frames $frames in $n parts, ranks sharing GPU 0 (the first pays the contexts)"
  CUDA_VISIBLE_DEVICES=0 mpirun -n $n --oversubscribe "$exe" render "$work/pour" --width 1920 \
    --height 1080 --no-film --split space --frames "$frames" --out "$work/c$n" | grep frame_
  cp "$work/c$n/frame_$(printf %06d "$last").png" "$out/sortlast/parts$n.png"
done
rm -rf "$work"
