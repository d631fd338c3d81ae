#!/usr/bin/env bash
# Every test of the CPU build under AddressSanitizer and UndefinedBehaviorSanitizer (the `asan`
# preset: g++, RelWithDebInfo, tests/sanitizers/ for what the libraries below us leak): reads
# and writes out of bounds, use after free, our own leaks, signed overflow, misaligned or
# out-of-range values, in the solver, the ranks' exchanges (the MPI tests under mpiexec as in
# CI), the snapshots and the renderer. Not part of .ci/run: the sanitized suite takes longer than
# CI's 40 minutes on 2 cores (docs/VALIDATION.md gives its time). Run it after a change to how
# memory is held or exchanged. Arguments go to ctest (`-R test_halo`, `-L mpi`).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
sup="$PWD/tests/sanitizers"
# Any report fails its test (exit code 1 from the runtime; a UB report halts at once).
# Leaks: Open MPI 4.1 and PMIx lose a few dozen bytes in MPI_Init, some inside components
# unloaded again before exit, whose frames only a full unwind reaches (tests/sanitizers/lsan.supp
# names their libraries). KF_SANITIZE_LEAKS=1 checks leaks with full unwinding, which deadlocks
# in libgcc's unwinder under llvmpipe's JIT: leave the render tests out then (-E test_render).
asan="strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1"
if [ "${KF_SANITIZE_LEAKS:-0}" = 1 ]; then
  export ASAN_OPTIONS="$asan:detect_leaks=1:fast_unwind_on_malloc=0"
else
  export ASAN_OPTIONS="$asan:detect_leaks=0"
fi
export LSAN_OPTIONS="suppressions=$sup/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$sup/ubsan.supp"
sym=$(command -v llvm-symbolizer || ls /usr/lib/llvm-*/bin/llvm-symbolizer 2>/dev/null | tail -1 || true)
[ -z "$sym" ] || export ASAN_SYMBOLIZER_PATH="$sym"
jobs=$(nproc)
cmake --preset asan >/dev/null
cmake --build --preset asan -j"$jobs"
ctest --preset asan -j"$jobs" --timeout 3600 "$@"
