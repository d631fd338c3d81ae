#!/usr/bin/env bash
# The quality presets on the coupled scenes, and the mesh obstacle's splash against resolution,
# after `. .devrt/prelude.sh`, from the project root:
# - the pour's and the wicking strip's whole runs (output off) as written, as "preview" (the
#   knit-fluid contact as stiff as at the scene's spacing) and as "preview" with the contact the
#   default rule gives at the preview's spacing (the preset before 2026-12-04, fifth): wall times;
# - mesh_obstacle.toml at its spacing (0.01 m), 0.005 and 0.0025 m to t = 0.4 s, snapshots at
#   0.2 and 0.4 s copied to OUTDIR (the splash's height and the energy, read on the CPU machine).
#
#   jobs/gpu/preview_checks.sh KNITFLOW OUTDIR
#
# 591.7 and 250.007 N/m are the rule's stiffnesses at the preview's spacing, as `knitflow plan
# SCENE --set 'solver.quality="preview"'` printed them before aeba307 (or `plan` now with
# --set fluid.spacing=2dp): re-read them if the scenes' fluid or knit change.
set -uo pipefail
exe=$1 out=$2
mkdir -p "$out"
whole() { # NAME SCENE [--set ...]
  local name=$1 scene=$2
  shift 2
  echo "-- $name ($(date -u +%T))"
  "$exe" run "$scene" --device cuda --set output.enabled=false --output "$out/o" "$@" 2>&1 |
    grep -E '^(done|particles|coupling):'
}
for round in 1 2; do
  echo "== round $round"
  whole "pour as written" scenes/pour.toml
  whole "pour preview" scenes/pour.toml --set 'solver.quality="preview"'
  whole "pour preview, the rule's contact" scenes/pour.toml --set 'solver.quality="preview"' \
    --set coupling.stiffness=591.7
  whole "wicking as written" scenes/wicking.toml
  whole "wicking preview" scenes/wicking.toml --set 'solver.quality="preview"'
  whole "wicking preview, the rule's contact" scenes/wicking.toml \
    --set 'solver.quality="preview"' --set coupling.stiffness=250.007
done
echo "== mesh_obstacle against spacing"
for dp in 0.01 0.005 0.0025; do
  echo "-- spacing $dp ($(date -u +%T))"
  "$exe" run scenes/mesh_obstacle.toml --device cuda --set fluid.spacing=$dp \
    --set simulation.end_time=0.4 --set output.interval=0.2 --output "$out/mo_$dp" 2>&1 |
    grep -E '^(done|particles):'
  for f in 1 2; do cp "$out/mo_$dp/frame_00000$f.h5" "$out/mo_${dp}_f$f.h5"; done
  rm -rf "$out/mo_$dp"
done
rm -rf "$out/o"
