#!/usr/bin/env bash
# Two builds side by side on one GPU and one rank (no loss on one rank; a kernel's cost): the
# dam break ("verlet", output off) at SIZES fluid particles, the marginal step between runs of
# STEPS=A,B steps (default 300,1,500; the done line's 0.01 s is 8 us a step over 1,200), the
# builds alternated ROUNDS times; then each build's kernel times (KF_KERNEL_TIMES=1) of the
# longer run, the kernels whose labels match KERNELS (default the grid's).
# After `. .devrt/prelude.sh`, from the project root:
#   ROUNDS=2 SIZES="1e6 4e6 8e6" jobs/gpu/one_rank_builds.sh OLD NEW
set -uo pipefail
rounds=${ROUNDS:-2}
read -ra sizes <<< "${SIZES:-1e6 4e6 8e6}"
IFS=, read -r s0 s1 <<< "${STEPS:-300,1500}"
run() { # exe spacing steps [env] -> the log
  "$1" run scenes/dambreak.toml --device cuda --set output.enabled=false \
    --set fluid.spacing="$2" --set 'solver.neighbour_list="verlet"' --set solver.max_steps="$3" 2>&1
}
secs() { grep -E '^done' | grep -oE 'in [0-9.]+ s wall' | head -1 | tr -dc '0-9.'; }
for n in "${sizes[@]}"; do
  dp=$(python3 -c "print('%.8g' % ((0.016 / float('$n')) ** (1 / 3)))")
  for r in $(seq "$rounds"); do
    for exe in "$@"; do
      ta=$(run "$exe" "$dp" "$s0" | secs) tb=$(run "$exe" "$dp" "$s1" | secs)
      echo "size $n round $r $(basename "$exe"): $s0 steps $ta s, $s1 steps $tb s; marginal" \
        "$(python3 -c "print(f'{1e3*($tb-$ta)/($s1-$s0):.3f}')") ms a step"
    done
  done
  for exe in "$@"; do
    echo "-- $(basename "$exe") $n: kernel times, $s1 steps (${KERNELS:-grid\.})"
    KF_KERNEL_TIMES=1 run "$exe" "$dp" "$s1" | sed -n '/^kernel times/,$p' |
      grep -E "kernel times|${KERNELS:-grid\.}" | head -16
  done
done
