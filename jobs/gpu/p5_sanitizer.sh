#!/usr/bin/env bash
# compute-sanitizer over the split on one GPU (after `. .devrt/prelude.sh`, from the project
# root): two ranks sharing the GPU, as P5's one-GPU checks run them.
#  - the MPI test programs' GPU cases (the transports: CUDA IPC and MPI staged through pinned
#    host messages; the halo's device rows; the dam break, the knit and the coupled pour split
#    on the GPU against the one-rank GPU run);
#  - knitflow's scenes on 2 ranks, small and short: the dam break with "verlet" lists and a
#    re-partition every 20 steps (and again with particle shifting), the pour (paper model), the
#    wicking strip (conserving model), the drape, the garment.
# Tools: memcheck (out-of-bounds and misaligned device accesses, CUDA API errors, device
# memory leaked at exit), racecheck (shared-memory hazards), synccheck (barriers), initcheck
# (device memory read before it was written; knitflow's runs only, over the MPI transport).
# Usage: jobs/gpu/p5_sanitizer.sh OUTDIR [TOOLS]   (default TOOLS "memcheck racecheck synccheck
#   initcheck"); one line a run: its rc and compute-sanitizer's summary, logs in OUTDIR.
#   SAN_ONLY="test_halo_mpi pour ..." keeps only the named runs (test programs or scenes): under
#   memcheck on an H100 the split dam break's tests take ~100 s, the scenes 1-4 s each.
#   SAN_FILTER replaces the test programs' gtest filters (one theme of the split alone, e.g.
#   SAN_ONLY=test_distributed_mpi SAN_FILTER='*OnTheGpuVerlet*': under racecheck the four themes
#   in one run had finished two of their twelve splits when a 560 s call was cut).
#   SAN_ARGS adds compute-sanitizer options (--print-limit N: 100 reports a rank by default).
#   SAN_STEPS=N runs every scene N steps (initcheck is the slowest tool: the dam break's 60 steps
#   passed 100 s; its first re-partition comes at step 20).
set -uo pipefail
out=$1 tools=${2:-memcheck racecheck synccheck initcheck}
mkdir -p "$out"
export PATH="$PATH:build/cuda/apps:build/cuda/tests"
san=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -1)
[ -n "$san" ] || { echo "no compute-sanitizer"; exit 2; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt"
"$san" --version | tail -1 >> "$out/gpu.txt"
. "$(dirname "$0")/../../scripts/sanitizer-scenes.sh"
fails=0
# places LOG...: the distinct places of the logs' reports (their kind, the device line, the first
# three of knitflow's host frames), most frequent first: what the print limit's 100 a rank show.
places() {
  awk '
    function flush() { if (key != "") n[key]++; key = ""; frames = 0 }
    /^========= [^ ]/ { flush(); if ($0 !~ /SUMMARY|COMPUTE-SANITIZER/) key = $0; next }
    key != "" && /^=========     at / { key = key " | " $0; next }
    key != "" && /Host Frame: kf::/ && $0 !~ /kf::exec::/ && frames < 3 {
      key = key " <- " $0; frames++ }
    END { flush(); for (k in n) print n[k] "x " k }' "$@" |
    sed -E 's/0x[0-9a-f]+//g; s/=========  *//g; s/Host Frame: //g; s/ \[\] in [a-z_]+//g' |
    sed -E 's/ at host access to  of size [0-9,]+ bytes//; s/  +/ /g' |
    awk '{c[substr($0, index($0, " ") + 1)] += $1} END {for (k in c) print c[k] "x " k}' |
    sort -rn | head -12 | sed 's/^/    /'
}
# check LABEL TOOL CMD...: runs CMD on 2 ranks, each rank under compute-sanitizer TOOL.
check() {
  local label=$1 tool=$2
  shift 2
  [ -z "${SAN_ONLY:-}" ] || [[ " $SAN_ONLY " == *" $label "* ]] || return 0
  local log="$out/${label}_${tool}"
  local t0=$SECONDS
  mpirun -n 2 --oversubscribe "$san" --tool "$tool" --error-exitcode 9 ${SAN_ARGS:-} \
    --log-file "$log.%p.san" "$@" > "$log.log" 2>&1
  local rc=$?
  local summary
  summary=$(grep -h -E 'ERROR SUMMARY|RACECHECK SUMMARY|LEAK SUMMARY' "$log".*.san | sort | uniq -c | tr -s ' ' | paste -sd';')
  echo "$label $tool rc=$rc $((SECONDS - t0)) s: ${summary:-no summary}"
  [ $rc -eq 0 ] || places "$log".*.san
  [ $rc -eq 0 ] || fails=$((fails + 1))
}
tests=(
  "test_transport_mpi TransportMpi.DeviceTransports*:TransportMpi.IpcCarries*:TransportMpi.FactoryChooses*"
  "test_halo_mpi Halo.DeviceRows*"
  "test_distributed_mpi Distributed.OnTheGpu*"
  "test_distributed_knit_mpi DistributedKnit.OnTheGpu*"
)
for tool in $tools; do
  small=(--device cuda --set output.enabled=false)
  # initcheck cannot see a peer process's writes to memory imported through CUDA IPC: every copy
  # out of a peer's packed buffer reads as uninitialized. The MPI transport carries the same
  # bytes staged through pinned host memory, each rank's device copies of its own memory checked.
  [ "$tool" = initcheck ] && small+=(--set 'parallel.transport="mpi"')
  if [ "$tool" != initcheck ]; then
    for t in "${tests[@]}"; do
      set -- $t
      check "$1" "$tool" "$1" --gtest_filter="${SAN_FILTER:-$2}"
    done
  fi
  check dambreak "$tool" knitflow run "${san_dambreak[@]}" "${small[@]}" --set solver.max_steps=${SAN_STEPS:-60}
  check shifting "$tool" knitflow run "${san_shifting[@]}" "${small[@]}" --set solver.max_steps=${SAN_STEPS:-60}
  check pour "$tool" knitflow run "${san_pour[@]}" "${small[@]}" --set solver.max_steps=${SAN_STEPS:-40}
  check wicking "$tool" knitflow run "${san_wicking[@]}" "${small[@]}" --set solver.max_steps=${SAN_STEPS:-40}
  check drape "$tool" knitflow run "${san_drape[@]}" "${small[@]}" --set solver.max_steps=${SAN_STEPS:-40}
  check garment "$tool" knitflow run "${san_garment[@]}" "${small[@]}" --set solver.max_steps=${SAN_STEPS:-20}
done
echo "runs failed: $fails"
[ $fails -eq 0 ]
