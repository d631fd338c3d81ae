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
# It runs for its 60 s beside the CUDA compile below (one core of the two; CI's 40 minutes).
stamp "fuzz: the scene parser, 60 s"
cmake -S fuzz -B build/fuzz -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build build/fuzz -j"$jobs" >/dev/null
rm -rf build/fuzz/corpus && mkdir -p build/fuzz/corpus
build/fuzz/fuzz_scene -max_total_time=60 -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
  build/fuzz/corpus scenes scenes/studies scenes/bench tests/data/scenes/broken \
  >build/fuzz/run.log 2>&1 &
fuzz=$!
if command -v nvcc >/dev/null 2>&1 || [ -x /usr/local/cuda/bin/nvcc ]; then
  # Compile only what the CUDA build compiles otherwise than the CPU build above
  # (scripts/cuda_check.py: nvcc's units through its front end and device compiler, the
  # transports (NCCL) and every other source or test naming KF_WITH_CUDA or __CUDACC__); the
  # rest is the same g++ code again (`cmake --build --preset cuda` builds everything, as the GPU
  # jobs do).
  # Its own tree (build/cuda-check; build/cuda stays the GPU jobs' Release build), configured
  # for the check alone: PTX without SASS (90-virtual: no ptxas), NVVM at -O0 (-Xcicc) and host
  # code at -O0 (no CMAKE_BUILD_TYPE's flags): Sph.cpp 61 -> 22 s, KnitFluidCoupling.cpp 46 ->
  # 20 s on CI's cores. The front ends, every template's instantiation and the device code's
  # generation still run; what is left out is optimisation, ptxas's register allocation and the
  # host compiler's pass over nvcc's host output (cuda_check.py says why).
  stamp "CUDA build (compile only: the kernels, the transports, the sources KF_WITH_CUDA changes)"
  cuda=build/cuda-check
  cmake --preset cuda -B "$cuda" -DKF_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=CompileCheck \
    -DCMAKE_CUDA_ARCHITECTURES=90-virtual -DCMAKE_CUDA_FLAGS="-Xcicc -O0" >/dev/null
  python3 scripts/cuda_check.py "$cuda" "$jobs"
fi
if ! wait "$fuzz"; then
  tail -40 build/fuzz/run.log
  echo "fuzz: the scene parser failed (build/fuzz/run.log)"
  exit 1
fi
tail -4 build/fuzz/run.log
stamp "done"
