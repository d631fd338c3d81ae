#!/usr/bin/env bash
# The stress suite (P8, tests/test_stress) at full size: every scene of scenes/stress as written,
# on the GPU, each case's measurements in one line (docs/VALIDATION.md's stress table). On a GPU
# machine after `. .devrt/prelude.sh`, from the project root; test_stress from PATH
# (scripts/pack-gpu.sh build/cuda/tests/test_stress) or build/cuda/tests.
#
#   jobs/gpu/p8_stress.sh [GTEST_FILTER]     # logs in $OUT (default out/p8_stress)
set -uo pipefail
out=${OUT:-out/p8_stress}
mkdir -p "$out"
exe=$(command -v test_stress || echo build/cuda/tests/test_stress)
KF_STRESS_FULL=1 KF_STRESS_DEVICE=cuda "$exe" --gtest_filter="${1:-*}" 2>&1 | tee "$out/stress.log"
status=${PIPESTATUS[0]}
grep -E "\(seed [0-9]+\):" "$out/stress.log" > "$out/stress_lines.txt"
exit "$status"
