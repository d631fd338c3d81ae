#!/usr/bin/env bash
# Installs what is missing, builds the CPU backend and runs every test (unit, physics, and the MPI
# tests under mpiexec -n 2). With nvcc present, also compiles the CUDA build (no GPU needed).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
jobs=$(nproc)
# Each phase's start, in seconds since this script began (CI's budget is 40 minutes on 2 cores).
stamp() { echo "== ${SECONDS} s: $*"; }
stamp "CPU build"
cmake --preset cpu >/dev/null
cmake --build --preset cpu -j"$jobs"
stamp "tests"
ctest --preset cpu -j"$jobs" --timeout 1500
# The scene parser under libFuzzer (fuzz/): a short run seeded with the shipped and the broken
# scenes; any crash, sanitizer report or exception other than a scene error fails CI.
stamp "fuzz: the scene parser, 60 s"
cmake -S fuzz -B build/fuzz -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build build/fuzz -j"$jobs" >/dev/null
rm -rf build/fuzz/corpus && mkdir -p build/fuzz/corpus
build/fuzz/fuzz_scene -max_total_time=60 -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
  build/fuzz/corpus scenes scenes/studies scenes/bench tests/data/scenes/broken 2>&1 | tail -4
if command -v nvcc >/dev/null 2>&1 || [ -x /usr/local/cuda/bin/nvcc ]; then
  stamp "CUDA build (compile only: kernels, library, app, the tests nvcc or KF_WITH_CUDA compile)"
  cmake --preset cuda -DKF_BUILD_BENCH=OFF >/dev/null
  cmake --build --preset cuda -j"$jobs" --target knitflow kf_cuda_tests
fi
stamp "done"
