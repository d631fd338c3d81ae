#!/usr/bin/env bash
# Every test program with GPU cases, on a GPU machine (after `. .devrt/prelude.sh`, from the
# project root); run it after each change to a kernel. A program has GPU cases when its source
# names Backend::Cuda, asks cuda_available or includes support/Backends.hpp: the rule
# tests/CMakeLists.txt labels `gpu` by
# (`ctest -L gpu` in a build tree), applied here to the sources since the GPU machine has no build
# tree. Binaries are found on PATH (.devrt/bin from scripts/pack-gpu.sh) or in build/cuda/tests.
#
#   jobs/gpu/gpu_tests.sh           # logs in $OUT (default out/gpu_tests), one line per program
#   jobs/gpu/gpu_tests.sh --list    # the programs' names, one a line, for packing:
#   scripts/pack-gpu.sh $(jobs/gpu/gpu_tests.sh --list | sed 's|^|build/cuda/tests/|') \
#     build/cuda/apps/knitflow
#
# Exit status 1 if a program is missing, exits non-zero, reports a failed test, or skipped a
# test for want of a CUDA device (a CPU-only binary, or no GPU visible): on this machine a GPU
# case that did not run counts as one that did not pass. GPU_TEST_TIMEOUT: seconds a program may
# run (default 1800).
set -uo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"

programs() {
  local src
  for src in "$root"/tests/test_*.cpp; do
    if grep -qF -e 'Backend::Cuda' -e 'cuda_available' -e 'support/Backends.hpp' "$src"; then
      basename "$src" .cpp
    fi
  done
}

case "${1:-}" in
--list)
  programs
  exit 0
  ;;
"") ;;
*)
  sed -n '2,/^set /p' "$0" | sed '$d; s/^# \{0,1\}//'
  exit 2
  ;;
esac

out=${OUT:-out/gpu_tests}
mkdir -p "$out" && out="$(cd "$out" && pwd)" || exit 1
export PATH="$PATH:$root/build/cuda/tests"
# The programs that run knitflow (test_watchdog, test_bad_input) take the packed one where the
# build tree's is absent (tests/support/TestPaths).
if [ -z "${KF_KNITFLOW:-}" ] && [ ! -x "$root/build/cuda/apps/knitflow" ] &&
  command -v knitflow > /dev/null; then
  KF_KNITFLOW="$(command -v knitflow)"
  export KF_KNITFLOW
fi
cd "$root" || exit 1 # where p4_check.sh and the packed binaries run from
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$out/gpu.txt" 2>&1 ||
  echo "no nvidia-smi answer" >> "$out/gpu.txt"
echo "gpu: $(head -1 "$out/gpu.txt")"

# gtest's summary: "[  PASSED  ] N tests.", "[  FAILED  ] N tests, listed below:", likewise
# SKIPPED; a program that crashed prints none of them.
count() { sed -nE "s/^\[  $1 +\] ([0-9]+) tests?[.,].*/\1/p" "$2" | tail -1; }

bad=0
for t in $(programs); do
  if ! command -v "$t" > /dev/null; then
    echo "$t MISSING (not on PATH nor in build/cuda/tests)"
    bad=1
    continue
  fi
  log="$out/$t.log"
  start=$SECONDS
  timeout "${GPU_TEST_TIMEOUT:-1800}" "$t" > "$log" 2>&1
  rc=$?
  passed=$(count PASSED "$log")
  failed=$(count FAILED "$log")
  skipped=$(count SKIPPED "$log")
  no_gpu=$(grep -c 'no CUDA device' "$log")
  echo "$t rc=$rc passed=${passed:-?} failed=${failed:-0} skipped=${skipped:-0}" \
    "no_cuda_skips=$no_gpu $((SECONDS - start)) s"
  if [ "$rc" -ne 0 ] || [ -z "$passed" ] || [ "${failed:-0}" -ne 0 ] || [ "$no_gpu" -ne 0 ]; then
    bad=1
  fi
done
if [ "$bad" -ne 0 ]; then
  echo "GPU tests: FAILED (logs in $out)"
else
  echo "GPU tests: all passed (logs in $out)"
fi
exit "$bad"
