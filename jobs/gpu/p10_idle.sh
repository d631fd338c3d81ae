#!/usr/bin/env bash
# Where the device waits for the host in the paper's pour: each stage's span on the device and
# the device's idle time before it (`run --profile-device`, nothing synchronised), for two
# knitflow binaries in one call, with the "verlet" lists' checks that waited for the device.
# After `. .devrt/prelude.sh`, from the project root:
#
#   jobs/gpu/p10_idle.sh BEFORE AFTER [SCENE]     # logs in $OUT/p10_idle (default out/p10_idle)
set -uo pipefail
before=$1 after=$2 scene=${3:-scenes/pour.toml}
out=${OUT:-out}/p10_idle
mkdir -p "$out"
for which in before after; do
  log="$out/$(basename "$scene" .toml)_${which}.log"
  "${!which}" run "$scene" --device cuda --set output.enabled=false --output "$out/o" \
    --profile-device >"$log" 2>&1
  echo "== $which: $(grep -E '^done' "$log" | sed 's/^done: //')"
  grep -E '^neighbour lists:' "$log" | sed 's/^/    /'
  sed -n '/^stages on the device/,/^[^ ]/p' "$log" | grep -E '^  ' | sed 's/^/    /'
done
rm -rf "$out/o"
