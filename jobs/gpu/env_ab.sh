#!/usr/bin/env bash
# One build, a switch read from the environment (VAR=0 against VAR=1), on one GPU and one rank:
# the dam break ("verlet", output off) at SIZES fluid particles, the marginal step between runs
# of STEPS=A,B steps (default 300,1,500), the two settings alternated ROUNDS times; then each
# setting's kernel times (KF_KERNEL_TIMES=1) of the longer run, the labels matching KERNELS; and
# the pour's first POUR_STEPS steps (default 4,000) each way, ROUNDS times.
# After `. .devrt/prelude.sh`, from the project root:
#   VAR=KF_WARP_QUEUE ROUNDS=2 SIZES="1e6 8e6" jobs/gpu/env_ab.sh KNITFLOW
set -uo pipefail
exe=$1 var=${VAR:?name the switch: VAR=...}
rounds=${ROUNDS:-2}
read -ra sizes <<< "${SIZES:-1e6 8e6}"
IFS=, read -r s0 s1 <<< "${STEPS:-300,1500}"
run() { # value spacing steps -> the log
  env "$var=$1" "$exe" run scenes/dambreak.toml --device cuda --set output.enabled=false \
    --set fluid.spacing="$2" --set 'solver.neighbour_list="verlet"' --set solver.max_steps="$3" 2>&1
}
secs() { grep -E '^done' | grep -oE 'in [0-9.]+ s wall' | head -1 | tr -dc '0-9.'; }
for n in "${sizes[@]}"; do
  dp=$(python3 -c "print('%.8g' % ((0.016 / float('$n')) ** (1 / 3)))")
  for r in $(seq "$rounds"); do
    for v in 0 1; do
      ta=$(run "$v" "$dp" "$s0" | secs) tb=$(run "$v" "$dp" "$s1" | secs)
      echo "size $n round $r $var=$v: $s0 steps $ta s, $s1 steps $tb s; marginal" \
        "$(python3 -c "print(f'{1e3*($tb-$ta)/($s1-$s0):.3f}')") ms a step"
    done
  done
  for v in 0 1; do
    echo "-- $var=$v $n: kernel times, $s1 steps (${KERNELS:-sph\.})"
    KF_KERNEL_TIMES=1 run "$v" "$dp" "$s1" | sed -n '/^kernel times/,$p' |
      grep -E "kernel times|${KERNELS:-sph\.}" | head -16
  done
done
for r in $(seq "$rounds"); do
  for v in 0 1; do
    echo "pour ${POUR_STEPS:-4000} $var=$v r$r: $(env "$var=$v" "$exe" run scenes/pour.toml \
      --device cuda --set output.enabled=false --set 'solver.neighbour_list="verlet"' \
      --set solver.max_steps="${POUR_STEPS:-4000}" 2>&1 | grep -E '^done')"
  done
done
