#!/usr/bin/env bash
# Builds side by side on one GPU and one rank, the paper's pour (its whole 1.5 s, output off):
# each build's run alternated ROUNDS times (the done line and the end state's diagnostics, which
# must agree between builds that change no arithmetic), then each build's kernel times
# (KF_KERNEL_TIMES=1) of one more run, the kernels whose labels match KERNELS (default the
# coupling's; KERNELS=none: no such run). The pour counterpart of one_rank_builds.sh. After
# `. .devrt/prelude.sh`, from the project root:
#   ROUNDS=3 jobs/gpu/pour_builds.sh OLD NEW [NEWER ...]
set -uo pipefail
rounds=${ROUNDS:-3}
run() { "$1" run scenes/pour.toml --device cuda --set output.enabled=false 2>&1; }
for r in $(seq "$rounds"); do
  for exe in "$@"; do
    run "$exe" | grep -E '^(done|coupling|absorption)' | sed "s|^|$(basename "$exe") round $r: |"
  done
done
[ "${KERNELS:-}" = none ] && exit 0
for exe in "$@"; do
  echo "-- $(basename "$exe"): kernel times (${KERNELS:-coupling\.})"
  KF_KERNEL_TIMES=1 run "$exe" | sed -n '/^kernel times/,$p' |
    grep -E "kernel times|${KERNELS:-coupling\.}" | head -24
done
