#!/usr/bin/env bash
# A rank that fails ends the whole job promptly with its message (P5): under mpiexec -n 2 one rank
# (KF_FAULT) throws an error, or raises SIGABRT or SIGSEGV, a few steps into the dam break while
# the other carries on into the next collective (snapshot writes). The job must end non-zero
# within the limit (no rank left hanging), and an error must name its rank.
# Usage: rank_failure.sh KNITFLOW SCENE MPIEXEC
set -uo pipefail
exe=$1 scene=$2 mpiexec=$3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail=0
for case in "1:3:error" "0:3:error" "1:3:abort" "1:3:segv"; do
  start=$(date +%s)
  KF_FAULT=$case OMP_NUM_THREADS=1 timeout 120 "$mpiexec" -n 2 --oversubscribe "$exe" run "$scene" \
    --quiet --set fluid.spacing=0.04 --set output.interval=0.001 --output "$out/run" \
    > "$out/log" 2>&1
  rc=$?
  took=$(( $(date +%s) - start ))
  rank=${case%%:*}
  if [ $rc -eq 0 ]; then
    echo "FAIL $case: the job exited 0"; fail=1
  elif [ $rc -eq 124 ]; then
    echo "FAIL $case: the job hung (killed after 120 s)"; fail=1
  elif [[ $case == *error ]] && ! grep -q "rank $rank: error: injected fault" "$out/log"; then
    echo "FAIL $case: no message from rank $rank"; cat "$out/log"; fail=1
  else
    echo "ok   $case: exit $rc after ${took} s"
  fi
done
exit $fail
