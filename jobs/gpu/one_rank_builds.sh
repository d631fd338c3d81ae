#!/usr/bin/env bash
# Two builds side by side on one GPU and one rank (no loss on one rank; a kernel's cost): the
# dam break ("verlet", output off) at SIZES fluid particles, the marginal step between runs of
# 300 and 1,500 steps, the builds alternated ROUNDS times; then each build's kernel times
# (KF_KERNEL_TIMES=1) of the longer run, the grid's kernels.
# After `. .devrt/prelude.sh`, from the project root:
#   ROUNDS=2 SIZES="1e6 4e6 8e6" jobs/gpu/one_rank_builds.sh OLD NEW
set -uo pipefail
rounds=${ROUNDS:-2}
read -ra sizes <<< "${SIZES:-1e6 4e6 8e6}"
run() { # exe spacing steps [env] -> the log
  "$1" run scenes/dambreak.toml --device cuda --set output.enabled=false \
    --set fluid.spacing="$2" --set 'solver.neighbour_list="verlet"' --set solver.max_steps="$3" 2>&1
}
secs() { grep -E '^done' | grep -oE 'in [0-9.]+ s wall' | head -1 | tr -dc '0-9.'; }
for n in "${sizes[@]}"; do
  dp=$(python3 -c "print('%.8g' % ((0.016 / float('$n')) ** (1 / 3)))")
  for r in $(seq "$rounds"); do
    for exe in "$@"; do
      ta=$(run "$exe" "$dp" 300 | secs) tb=$(run "$exe" "$dp" 1500 | secs)
      echo "size $n round $r $(basename "$exe"): 300 steps $ta s, 1500 steps $tb s; marginal" \
        "$(python3 -c "print(f'{1e3*($tb-$ta)/1200:.3f}')") ms a step"
    done
  done
  for exe in "$@"; do
    echo "-- $(basename "$exe") $n: kernel times, 1500 steps (grid's kernels)"
    KF_KERNEL_TIMES=1 run "$exe" "$dp" 1500 | sed -n '/^kernel times/,$p' | grep -E 'kernel times|grid\.' | head -12
  done
done
