#!/usr/bin/env bash
# Builds side by side with RANKS (2) ranks sharing one GPU (run it under jobs/gpu/with_mps.sh; the
# MPI transport, rows staged through the host): the dam break with "verlet" lists, output off,
# at 4M in all (2M a rank) and 8M in all (4M a rank), each run for STEPS_A and STEPS_B steps so
# that the marginal step (their difference) leaves the start out; the builds alternated ROUNDS
# times. After `. .devrt/prelude.sh`, from the project root.
# Usage: ROUNDS=2 STEPS_A=300 STEPS_B=1500 jobs/gpu/p5_builds_shared.sh KNITFLOW[@KEY=VALUE]...
#   prints a line a pair of runs: their seconds, the marginal ms a step, the longer run's split
#   line. DEVICE (cuda), SIZES ("4M 0.0015874,8M 0.0012599": label and spacing) for a dry run.
#   KNITFLOW@KEY=VALUE runs that build with `--set KEY=VALUE` (one build, two settings:
#   'build/knitflow@parallel.transport="mpi"' 'build/knitflow@parallel.transport="ipc"').
set -uo pipefail
rounds=${ROUNDS:-2} sa=${STEPS_A:-300} sb=${STEPS_B:-1500}
run() { # exe[@key=value] spacing steps -> "seconds | split line"
  local log exe=${1%%@*} extra=()
  [[ $1 == *@* ]] && extra=(--set "${1#*@}")
  log=$(mpirun -n "${RANKS:-2}" --oversubscribe "$exe" run scenes/dambreak.toml --device "${DEVICE:-cuda}" --threads 4 \
    --set output.enabled=false --set fluid.spacing="$2" --set 'solver.neighbour_list="verlet"' \
    --set solver.max_steps="$3" "${extra[@]}" 2>&1)
  local secs
  secs=$(echo "$log" | grep -E '^done' | grep -oE 'in [0-9.]+ s wall' | head -1 | tr -dc '0-9.')
  echo "$secs | $(echo "$log" | grep -E '^(split|ranks:|grids)' | tr '\n' ' ')"
}
for r in $(seq "$rounds"); do
  for exe in "$@"; do
    IFS=, read -ra sizes <<< "${SIZES:-4M 0.0015874,8M 0.0012599}"
    for size in "${sizes[@]}"; do
      read -r label spacing <<< "$size"
      a=$(run "$exe" "$spacing" "$sa") b=$(run "$exe" "$spacing" "$sb")
      ta=${a%% |*} tb=${b%% |*}
      echo "round $r $(basename "$exe") $label: $sa steps $ta s, $sb steps $tb s;" \
        "marginal $(python3 -c "print(f'{1e3*($tb-$ta)/($sb-$sa):.3f}')") ms a step; ${b#*| }"
    done
  done
done
