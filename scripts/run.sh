#!/usr/bin/env bash
# The main job: installs what is missing, builds, runs the default scene (a 3D dam break),
# writing snapshots (HDF5 + XDMF for ParaView) to out/dambreak, then draws them as pictures in
# out/dambreak/render. Extra arguments go to `knitflow run`, e.g. scripts/run.sh --set
# fluid.spacing=0.005
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
preset=cpu
if command -v nvidia-smi >/dev/null 2>&1 && nvidia-smi -L >/dev/null 2>&1; then preset=cuda; fi
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j"$(nproc)" --target knitflow
scene=${KF_SCENE:-scenes/dambreak.toml}
build/$preset/apps/knitflow plan "$scene" "$@"
build/$preset/apps/knitflow run "$scene" "$@"
out=out/$(basename "$scene" .toml)
build/$preset/apps/knitflow render "$out" --quiet
last=$(ls "$out"/render/frame_*.png | tail -1)
film=""
[ -f "$out/render/film.mp4" ] && film="; film: $out/render/film.mp4"
echo "snapshots: $out/snapshots.xmf (open in ParaView); pictures: $out/render/ (the last: $last)$film"
