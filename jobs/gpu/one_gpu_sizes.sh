#!/usr/bin/env bash
# Where a dam break's step goes at each size on one GPU: the marginal step (runs of A and B
# steps), each stage's span on the device (`--profile-device`, nothing synchronised) and the
# kernels' times (`KF_KERNEL_TIMES=1`) of the longer run. P5's model prices a rank of a strong
# split at one GPU's rate for its size; this shows what makes the small sizes' particle-step dear.
# After `. .devrt/prelude.sh`, from the project root:
#
#   jobs/gpu/one_gpu_sizes.sh KNITFLOW OUTDIR [SIZE...]    # fluid particles, default 1e6 4e6
#
# STEPS=A,B (default 300,1500); EXTRA="--set k=v ..." extra overrides for every run.
set -uo pipefail
exe=$1 out=$2
shift 2
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(1e6 4e6)
IFS=, read -r s0 s1 <<< "${STEPS:-300,1500}"
mkdir -p "$out"
read -ra extra <<< "${EXTRA:-}"

for n in "${sizes[@]}"; do
  dp=$(python3 -c "print('%.8g' % ((0.016 / float('$n')) ** (1 / 3)))")
  common=(run scenes/dambreak.toml --device cuda --set 'solver.neighbour_list="verlet"'
    --set "fluid.spacing=$dp" --set output.enabled=false --output "$out/o" "${extra[@]}")
  for s in $s0 $s1; do
    "$exe" "${common[@]}" --set "solver.max_steps=$s" --profile-device > "$out/size_${n}_$s.log" 2>&1
  done
  KF_KERNEL_TIMES=1 "$exe" "${common[@]}" --set "solver.max_steps=$s1" > "$out/size_${n}_kernels.log" 2>&1
  echo "=== $n fluid (dp $dp)"
  for s in $s0 $s1; do grep -E '^done' "$out/size_${n}_$s.log"; done
  echo "-- stages on the device, $s1 steps"
  sed -n '/^stages on the device/,/^[^ ]/p' "$out/size_${n}_$s1.log" | grep -E '^  '
  echo "-- kernels, $s1 steps"
  sed -n '/^kernel times/,$p' "$out/size_${n}_kernels.log" | head -${KERNEL_ROWS:-16}
done
rm -rf "$out/o"
