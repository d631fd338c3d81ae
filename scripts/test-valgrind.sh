#!/usr/bin/env bash
# knitflow's scenes on the CPU backend under Valgrind's memcheck, on 1 and on 2 ranks: a
# decision or a system call made on a value never written, and a copy out of the backend's
# memory of bytes never written (`exec::copy_bytes` asks memcheck: a column's growth copying slots
# nothing wrote, as compute-sanitizer's initcheck reports on the GPU), reads and writes past a
# block, frees gone wrong. The CPU backend's buffers come from
# `exec::alloc_bytes` unwritten, so a pass that reads a slot nothing wrote shows here where the
# poisoned runs (KF_POISON_ALLOCATIONS, which this run must not set: the 0xFF fill counts as
# written) show only a read whose NaN reaches a result. The scenes as jobs/gpu/p5_sanitizer.sh
# runs them (the pour's stream just above the knit, the wicking strip's foot in its pool, the
# dam break re-partitioned every 20 steps, with particle shifting too), the coupling running
# within the steps. Not part of .ci/run (memcheck runs a step ~50x slower; all at 200 steps:
# ~5 min on 2 cores). Release build: frames name functions, not lines. Then snapshots and
# restart across rank counts (below).
# Usage: scripts/test-valgrind.sh [STEPS] [RUNS]   (default 200; RUNS e.g. "pour wicking restart";
#   "tests" adds the MPI test programs)
#   logs in build/valgrind/; one line a run; exit 1 if any run reports.
set -uo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || {
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends valgrind >/dev/null
}
scripts/install-deps.sh
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
[ -x build/cpu/apps/knitflow ] || { cmake --preset cpu >/dev/null && cmake --build build/cpu -j"$(nproc)" --target knitflow >/dev/null; }
steps=${1:-200} only=${2:-}
out=build/valgrind
mkdir -p "$out"
rm -f "$out"/*.vg
unset KF_POISON_ALLOCATIONS
export OMP_NUM_THREADS=1
# Open MPI's own (its shared file) and the few PMIx / Open MPI reports it lacks (ours).
supp=(--suppressions=/usr/share/openmpi/openmpi-valgrind.supp
  --suppressions="$PWD/tests/sanitizers/valgrind.supp")
fails=0
memcheck() { # RANKS LOG CMD...: CMD on RANKS ranks, each under memcheck; its output in LOG.log
  local ranks=$1 log=$2
  shift 2
  mpiexec -n "$ranks" --oversubscribe valgrind --tool=memcheck --error-limit=no --track-origins=yes \
    --num-callers=20 --error-exitcode=9 "${supp[@]}" --log-file="$log.%p.vg" "$@" > "$log.log" 2>&1
}
reported() { grep -h "ERROR SUMMARY" "$1".*.vg | awk '{s += $4} END {print s + 0}'; } # LOG
check() { # LABEL RANKS ARGS...   (IO=ARGS: the run's output, none by default; N=STEPS)
  local label=$1 ranks=$2
  shift 2
  [ -z "$only" ] || [[ " $only " == *" ${label%%_*} "* ]] || return 0
  local log="$out/${label}_np$ranks" t0=$SECONDS
  memcheck "$ranks" "$log" build/cpu/apps/knitflow run "$@" --device cpu \
    ${IO:---set output.enabled=false} --set solver.max_steps="${N:-$steps}"
  local rc=$?
  local errors
  errors=$(reported "$log")
  echo "$label, $ranks rank(s): rc=$rc, $errors errors, $((SECONDS - t0)) s; $(grep -h -E '^coupling:' "$log.log" | head -1)"
  if [ $rc -ne 0 ] || [ "$errors" != 0 ]; then
    fails=$((fails + 1))
    # Each report's kind and its first three of knitflow's frames, most frequent first.
    awk '/^==[0-9]+== [A-Z]/ && !/SUMMARY|Memcheck|Copyright|Using|Command|HEAP|LEAK|in use|total heap|definitely|indirectly|possibly|still|suppressed|For lists|Rerun|Thread|Uninitialised value was created/ {
           if (key != "") print key; key = substr($0, index($0, " ") + 1); n = 0; next }
         key != "" && /kf::/ && n < 3 { sub(/.*: /, ""); key = key " <- " $0; n++ }
         END { if (key != "") print key }' "$log".*.vg | sed -E 's/ \(in [^)]*\)//g' |
      sort | uniq -c | sort -rn | head -8 | sed 's/^/    /'
  fi
}
. scripts/sanitizer-scenes.sh
for ranks in 1 2; do
  for scene in dambreak shifting pour wicking drape garment; do
    args="san_$scene[@]"
    check "$scene" "$ranks" "${!args}"
  done
done
# Snapshots and restart (the parallel HDF5 writer and reader, the conserving absorption's
# state): the strip on 2 ranks writes a frame at t = 0.005 s (~110 steps), and continues from it
# on 1 and on 3 ranks for 100 steps more.
rm -rf "$out"/frames*
io=(--output "$out/frames" --set output.interval=0.005)
IO="${io[*]}" N=$((steps > 150 ? steps : 150)) check restart_write 2 "${san_wicking[@]}"
frame=$(ls "$out"/frames/frame_*.h5 2>/dev/null | tail -1)
for ranks in 1 3; do # each from the 2 ranks' newest frame, writing elsewhere
  IO="--output $out/frames_np$ranks --set output.interval=0.005 --restart ${frame:-none}" \
    N=$(((steps > 150 ? steps : 150) + 100)) check restart_read "$ranks" "${san_wicking[@]}"
done
# The MPI test programs on 2 ranks, only when asked (RUNS naming "tests"; test_distributed_mpi
# takes ~20 s in CI, far longer under memcheck): the transports, the snapshots, the split's
# equality with one rank. Each program's own checks must pass too (rc). The knit's split tests
# without its coupled ones (those take ~80 of its ~90 s; the pour and the strip on 2 ranks above
# run the coupling): the knit's halo, its rows' localization at a rebuild, the plan.
knit_filter='DistributedKnit.Drape*:*NoRank*:*FoldingStrip*:*Ghosts*:*TheRowsTravel*:*ThePlan*'
if [[ " $only " == *" tests "* ]]; then
  for t in test_transport_mpi test_snapshot_mpi test_halo_mpi test_distributed_mpi \
    test_distributed_knit_mpi; do
    [ -x "build/cpu/tests/$t" ] || cmake --build build/cpu -j"$(nproc)" --target "$t" >/dev/null
    log="$out/$t" t0=$SECONDS
    filter=()
    [ "$t" = test_distributed_knit_mpi ] && filter=(--gtest_filter="$knit_filter")
    memcheck 2 "$log" "build/cpu/tests/$t" "${filter[@]}"
    rc=$?
    errors=$(reported "$log")
    echo "$t, 2 ranks: rc=$rc, $errors errors, $((SECONDS - t0)) s"
    [ $rc -eq 0 ] && [ "$errors" = 0 ] || fails=$((fails + 1))
  done
fi
echo "runs reporting: $fails"
[ $fails -eq 0 ]
