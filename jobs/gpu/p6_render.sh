#!/usr/bin/env bash
# P6 on a GPU machine (after `. .devrt/prelude.sh`, from the project root): the paper's pour and
# drape run on the GPU and rendered on the GPU's EGL device. Prints each frame's time split (read,
# the fluid's surface, the yarns' tubes, draw with shadows and read-back, PNG; the GPU's passes by
# GL timestamps) at 1920 x 1080, the same with the geometry built on the host, without shadows, close-ups of the stitches, the compositing of one frame over
# 2 and 4 ranks sharing GPU 0 (and over a GPU a rank where the host has several), and leaves in
# OUTDIR: the chosen pictures (pour dry and wet, the drape) and film.tar (960 x 540 frames).
# Usage: jobs/gpu/p6_render.sh KNITFLOW OUTDIR [POUR_END]   (POUR_END: default 0.6 s)
set -uo pipefail
exe=$1 out=$2 end=${3:-0.6} dev=${DEVICE:-cuda} drape_end=${DRAPE_END:-1.5}
mkdir -p "$out/pick"
work=$(mktemp -d)
gpus=$(nvidia-smi -L | wc -l)
echo "== pour on the GPU to t = $end s, a snapshot every 0.02 s"
"$exe" run scenes/pour.toml --device "$dev" --quiet --set simulation.end_time="$end" \
  --set output.interval=0.02 --output "$work/pour" | tail -2
last=$(ls "$work/pour"/frame_*.h5 | tail -1 | sed -E 's/.*frame_0*([0-9]+)\.h5/\1/')
echo "== render 1920 x 1080, every frame (the first pays the context and shaders)"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --out "$work/full" | grep frame_ |
  sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== frames 5 and $last with the surface and the tubes built on the host (the reference path)"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "5:$last:$((last > 5 ? last - 5 : 1))" \
  --set render.gpu_geometry=false --out "$work/host" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== the same, the water opaque (refraction off: no layers, no resolve), frames 5 and $last"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "5:$last:$((last > 5 ? last - 5 : 1))" \
  --set render.refraction=false --out "$work/opaque" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== the same, the yarns as lit tubes (no lumislice: no slices to order and blend), frames 5 and $last"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "5:$last:$((last > 5 ? last - 5 : 1))" \
  --set render.yarn_volume=false --out "$work/tubes" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== the same, every yarn segment its 4 slices (no level of detail), frames 5 and $last"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "5:$last:$((last > 5 ? last - 5 : 1))" \
  --set render.yarn_detail_pixels=0 --out "$work/slices" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== the same, fluid as spheres (the preview's look), frames 5 and $last"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --fluid spheres \
  --frames "5:$last:$((last > 5 ? last - 5 : 1))" --out "$work/spheres" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== frames 5 and $last without shadows and floor, and with the knit as points"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "5:$last:$((last > 5 ? last - 5 : 1))" \
  --set render.shadows=false --set render.floor=false --out "$work/noshadow" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "5:$last:$((last > 5 ? last - 5 : 1))" \
  --knit points --out "$work/points" | grep frame_ | sed 's/^render: [^ ]*\(frame_[0-9]*\)/\1/'
echo "== close-ups: the jet on the knit (frame 5), the wet edge (frame $last)"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames 5:5:1 --out "$work/close_jet" \
  --set 'render.eye=[0.12,-0.16,0.62]' --set 'render.target=[0.03,-0.03,0.52]' | grep frame_
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "$last:$last:1" --out "$work/close_edge" \
  --set 'render.eye=[0.33,-0.45,0.62]' --set 'render.target=[0.2,-0.26,0.45]' | grep frame_
cp "$work/close_jet/frame_000005.png" "$out/pick/pour_close_dry.png"
cp "$work/close_edge/frame_$(printf %06d "$last").png" "$out/pick/pour_close_wet.png"
"$exe" render "$work/pour" --width 1920 --height 1080 --no-film --frames "$((last - 4)):$last:1" --out "$work/c1" | grep frame_
for n in 2 4; do
  echo "== frames $((last - 4))-$last in $n parts, ranks sharing GPU 0 (the first pays the contexts)"
  CUDA_VISIBLE_DEVICES=0 mpirun -n $n --oversubscribe "$exe" render "$work/pour" --width 1920 \
    --height 1080 --no-film --split space --frames "$((last - 4)):$last:1" --out "$work/c$n" | grep frame_
  cmp "$work/c1/frame_$(printf %06d "$last").png" "$work/c$n/frame_$(printf %06d "$last").png" &&
    echo "   the same picture as one rank's"
  if [ "$gpus" -ge "$n" ]; then
    echo "== frame $last in $n parts, a GPU a rank"
    mpirun -n $n "$exe" render "$work/pour" --width 1920 --height 1080 --no-film --split space \
      --frames "$last:$last:1" --out "$work/g$n" | grep frame_
  fi
done
echo "== film frames, 960 x 540"
"$exe" render "$work/pour" --width 960 --height 540 --no-film --quiet --out "$work/film"
tar cf "$out/film.tar" -C "$work/film" .
cp "$work/full/frame_000005.png" "$out/pick/pour_dry.png"
cp "$work/full/frame_000015.png" "$out/pick/pour_splash.png" 2>/dev/null
cp "$work/full/frame_$(printf %06d "$last").png" "$out/pick/pour_wet.png"
echo "== drape on the GPU ($drape_end s), its last frame"
"$exe" run scenes/drape.toml --device "$dev" --quiet --set simulation.end_time="$drape_end" --set output.interval="$(awk "BEGIN { print $drape_end / 3 }")" --output "$work/drape" | tail -1
"$exe" render "$work/drape" --width 1920 --height 1080 --no-film --frames 3:3:1 --out "$work/drape_png" | grep frame_
cp "$work/drape_png/frame_000003.png" "$out/pick/drape.png"
rm -rf "$work"
