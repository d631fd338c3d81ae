#!/usr/bin/env bash
# The checks the coupling's rows for the near fluid only still owe a GPU (written 2026-12-05,
# fifth, when no GPU was lent): every GPU test program (test_coupling_K's RowsPastTheRoom case
# among them), the paper's pour whole twice (its time against the last recorded figures, 13.4-
# 13.6 s on one H100 at 729119c: docs/data/p5_h100_2026-12-05c/pour_rounds.log) and once with
# --profile (the backend's peak by buffer), and the split's GPU cases on 2 ranks sharing the GPU
# through MPS. After `. .devrt/prelude.sh` with the binaries packed by
#   PACK_XZ=1 scripts/pack-gpu.sh $(jobs/gpu/gpu_tests.sh --list | sed 's|^|build/cuda/tests/|') \
#     build/cuda/tests/test_distributed_mpi build/cuda/tests/test_distributed_knit_mpi \
#     build/cuda/apps/knitflow
# and unpacked (`mkdir -p .devrt/bin && tar xJf .devrt/bin.tar.xz -C .devrt/bin`), from the
# project root: jobs/gpu/coupling_rows_check.sh OUT
set -uo pipefail
out=${1:?usage: coupling_rows_check.sh OUT}
mkdir -p "$out"
nvidia-smi -L > "$out/gpu.txt"
OUT=$out/gpu_tests GPU_TEST_TIMEOUT=300 jobs/gpu/gpu_tests.sh > "$out/gpu_tests.txt" 2>&1
tail -1 "$out/gpu_tests.txt"
for r in 1 2; do
  echo "== round $r"
  knitflow run scenes/pour.toml --device cuda --set output.enabled=false 2>&1 |
    grep -E '^(done|memory|coupling|absorption)'
done | tee "$out/pour_rounds.log"
knitflow run scenes/pour.toml --device cuda --set output.enabled=false --profile \
  > "$out/pour_profile.log" 2>&1
sed -n '/^memory/,/^knit:/p' "$out/pour_profile.log"
for t in test_distributed_knit_mpi test_distributed_mpi; do
  jobs/gpu/with_mps.sh timeout 200 mpirun -n 2 "$t" \
    --gtest_filter='*OnTheGpu*:*PlansMemory*:*NoRankHolds*' > "$out/$t.log" 2>&1
  echo "$t rc=$?"
done
