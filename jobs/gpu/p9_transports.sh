#!/usr/bin/env bash
# The transports side by side on the GPUs of one host, one rank a GPU (mpi: staged through the
# host), after `. .devrt/prelude.sh`, from the project root. Parts, any of:
#   tests   test_transport_mpi on 2 ranks (its nccl cases run where each rank has a GPU)
#   match   the dam break (0.3 s, frames every 0.1 s) on 2 GPUs with each transport: the frames
#           land in OUTDIR/match_<transport> for jobs/studies/match_runs.py
#   steady  the dam break at 4M fluid a GPU on 2 GPUs, each transport in turn (REPS rounds,
#           alternated), runs of 300 and 1,500 steps: the marginal step from the done lines;
#           DEVICE_PROFILE=1 adds --profile-device (the refreshes' passes and exchanges)
# Usage: jobs/gpu/p9_transports.sh KNITFLOW OUTDIR PART...
# TRANSPORTS (default "nccl mpi"), REPS (default 2), THREADS (default 4).
set -uo pipefail
exe=$1 out=$2
shift 2
mkdir -p "$out/logs"
transports=${TRANSPORTS:-nccl mpi}
threads=${THREADS:-4}
prof=()
[ "${DEVICE_PROFILE:-0}" = 1 ] && prof=(--profile-device)
for part in "$@"; do
  echo "=== $part ($(date -u +%T))"
  case $part in
  tests)
    timeout 300 mpirun -n 2 --bind-to none test_transport_mpi > "$out/logs/transport.log" 2>&1
    echo "test_transport_mpi rc=$?"
    grep -E 'PASSED|FAILED|SKIPPED' "$out/logs/transport.log" | sort | uniq -c
    ;;
  match)
    for t in $transports; do
      mpirun -n 2 --bind-to none "$exe" run scenes/dambreak.toml --device cuda --quiet \
        --threads "$threads" --set simulation.end_time=0.3 --set output.interval=0.1 \
        --set "parallel.transport=\"$t\"" --output "$out/match_$t" 2>&1 | tail -2
      rm -f "$out/match_$t"/*.xmf
    done
    ;;
  steady)
    # 4M fluid a rank on 2 ranks (fluid.spacing as jobs/studies/scaling.py sets it for 8M)
    for rep in $(seq 1 "${REPS:-2}"); do
      for t in $transports; do
        for s in 300 1500; do
          log="$out/logs/${t}_r${rep}_s$s.log"
          mpirun -n 2 --bind-to none "$exe" run scenes/dambreak.toml --device cuda \
            --threads "$threads" --set output.enabled=false --set solver.max_steps=$s \
            --set fluid.spacing=0.0012599210 --set 'solver.neighbour_list="verlet"' \
            --set "parallel.transport=\"$t\"" "${prof[@]}" > "$log" 2>&1
          echo "$t r$rep s$s rc=$? $(grep -E 'done' "$log" | tail -1)"
        done
      done
    done
    ;;
  *) echo "unknown part $part" ;;
  esac
done
echo "=== end ($(date -u +%T))"
(cd "$out" && tar czf logs.tar.gz logs && rm -rf logs)
