#!/usr/bin/env bash
# The split's density pass with its interior beside the border and the exchange (the side
# stream, the default) or after them (KF_SIDE_STREAM=0), ranks sharing one GPU through MPS: the
# dam break ("verlet", output off) in CASES of RANKS:SIZE fluid particles. Each case: the
# marginal step between runs of STEPS=A,B steps, the two ways alternated ROUNDS times; then one
# --profile-device run each way (the refreshes' passes timed on the device, rank 0 and the
# slowest). After `. .devrt/prelude.sh`, from the project root:
#   ROUNDS=2 CASES="2:2e6 2:8e6 8:8e6" bash jobs/gpu/with_mps.sh bash jobs/gpu/p5_side_stream.sh KNITFLOW
set -uo pipefail
exe=$1
rounds=${ROUNDS:-2}
read -ra cases <<< "${CASES:-2:2e6 2:8e6 8:8e6}"
IFS=, read -r s0 s1 <<< "${STEPS:-300,1300}"
run() { # ranks spacing steps side [args] -> the log
  local np=$1 dp=$2 steps=$3 side=$4
  shift 4
  KF_SIDE_STREAM=$side mpirun -n "$np" --oversubscribe -x KF_SIDE_STREAM "$exe" run \
    scenes/dambreak.toml --device cuda --set output.enabled=false --set fluid.spacing="$dp" \
    --set 'solver.neighbour_list="verlet"' --set solver.max_steps="$steps" "$@" 2>&1
}
secs() { grep -E '^done' | grep -oE 'in [0-9.]+ s wall' | head -1 | tr -dc '0-9.'; }
for c in "${cases[@]}"; do
  IFS=: read -r np n <<< "$c"
  dp=$(python3 -c "print('%.8g' % ((0.016 / float('$n')) ** (1 / 3)))")
  for r in $(seq "$rounds"); do
    for side in 0 1; do
      ta=$(run "$np" "$dp" "$s0" "$side" | secs) tb=$(run "$np" "$dp" "$s1" "$side" | secs)
      echo "ranks $np size $n round $r side $side: $s0 steps $ta s, $s1 steps $tb s; marginal" \
        "$(python3 -c "print(f'{1e3*($tb-$ta)/($s1-$s0):.3f}')") ms a step"
    done
  done
  for side in 0 1; do
    echo "-- ranks $np size $n side $side: --profile-device, $s1 steps"
    run "$np" "$dp" "$s1" "$side" --profile --profile-device |
      grep -E '^(done|split|refreshes|  the slowest)'
  done
done
