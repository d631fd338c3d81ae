#!/usr/bin/env bash
# The whole pour's and the whole drape's GPU time per kernel (`KF_KERNEL_TIMES=1`: CUDA events
# around every launch, so the runs are slower than untimed), with one knitflow binary; the logs
# in DIR, the tables printed. After `. .devrt/prelude.sh`, from the project root:
#
#   jobs/gpu/knit_kernel_times.sh KNITFLOW DIR
set -uo pipefail
exe=$1 out=$2
mkdir -p "$out"
for scene in pour:25 drape:12; do
  name=${scene%%:*}
  KF_KERNEL_TIMES=1 "$exe" run "scenes/$name.toml" --device cuda --set output.enabled=false \
    --output "$out/o" >"$out/${name}_kernels.log" 2>&1
  grep -A"${scene##*:}" 'kernel times' "$out/${name}_kernels.log"
done
rm -rf "$out/o"
