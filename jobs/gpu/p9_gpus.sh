#!/usr/bin/env bash
# P9 on one host with several GPUs, one rank a GPU (NCCL), after `. .devrt/prelude.sh`, from the
# project root. Parts, any of:
#   machine  GPUs, their links (nvidia-smi topo), NCCL and Open MPI (CUDA-aware or not)
#   tests    P5's MPI tests' GPU cases and the transport/halo/snapshot tests on 2 ranks, a GPU each
#   match    the dam break and the pour on 1 and on 2 GPUs, snapshots matched by global id
#   weak     dam break 4M fluid a GPU, and the pour scaled up with the GPUs, on 1, 2, 4, ... GPUs
#   strong   dam breaks of 8M and 32M fluid on 1, 2, 4, ... GPUs
#   steady   the dam break at 4M fluid a GPU, its step at steady state: the marginal step between
#            runs of 300 and 1,500 steps (STEADY=A,B to change them)
# Usage: jobs/gpu/p9_gpus.sh KNITFLOW OUTDIR PART...   (tests are found on PATH: .devrt/bin)
# STEPS (default 300) steps a scaling run; THREADS (default 4) OpenMP threads a rank for set-up;
# PROFILE=1 times every stage (the logs' stage tables; it synchronises the device after each).
# STRONG_TOTAL (default 8e6,32e6) the strong series' totals. RANKS (default 1,2,4,... up to the
# GPUs) the rank counts.
# Every run's log is packed into OUTDIR/logs.tar.gz at the end.
set -uo pipefail
exe=$1 out=$2
shift 2
mkdir -p "$out"
gpus=$(nvidia-smi -L | wc -l)
ranks=1
for ((r = 2; r <= gpus; r *= 2)); do ranks="$ranks,$r"; done
ranks=${RANKS:-$ranks}
steps=${STEPS:-300} threads=${THREADS:-4}
verlet=(--set 'solver.neighbour_list="verlet"')
prof=()
[ "${PROFILE:-0}" = 1 ] && prof=(--profile)

for part in "$@"; do
  echo "=== $part ($(date -u +%T))"
  case $part in
  machine)
    nvidia-smi -L
    nvidia-smi topo -m
    ompi_info --parsable --all 2>/dev/null | grep -i 'cuda_support' | head -3
    ls "$(dirname "$(command -v "$exe")")"/../lib 2>/dev/null | grep -i nccl | head -2
    ;;
  tests)
    for t in test_transport_mpi test_halo_mpi test_snapshot_mpi; do
      echo "-- $t"
      timeout 300 mpirun -n 2 --bind-to none "$t" 2>&1 | grep -E 'PASSED|FAILED|SKIPPED|nccl' | tail -25
    done
    for t in test_distributed_mpi test_distributed_knit_mpi; do
      echo "-- $t (GPU cases)"
      timeout 400 mpirun -n 2 --bind-to none "$t" --gtest_filter='*Gpu*' 2>&1 |
        grep -E 'PASSED|FAILED|SKIPPED|OK \]|identical|part' | tail -30
    done
    ;;
  match)
    for scene in ${MATCH_SCENES:-dambreak pour}; do
      case $scene in
      dambreak) set_=(--set simulation.end_time=0.3 --set output.interval=0.1) ;;
      pour) set_=(--set simulation.end_time=0.15 --set output.interval=0.05) ;;
      esac
      for n in 1 2; do
        mpirun -n $n --bind-to none "$exe" run "scenes/$scene.toml" --device cuda --quiet \
          --threads "$threads" "${set_[@]}" --output "$out/match_${scene}_np$n" 2>&1 | tail -3
      done
      if /usr/bin/python3 -c 'import h5py, numpy' 2> /dev/null; then
        /usr/bin/python3 jobs/studies/match_runs.py "$out/match_${scene}_np1" "$out/match_${scene}_np2" ||
          echo "(ids differ or a frame is missing)"
        rm -rf "$out/match_${scene}_np1" "$out/match_${scene}_np2"
      else # no h5py here: keep frames 1 and 3 to compare elsewhere
        echo "no h5py: frame 3 kept in $out/match_${scene}_np{1,2} (in 16 MB pieces)"
        rm -f "$out"/match_"${scene}"_np?/frame_00000[012].h5 "$out"/match_"${scene}"_np?/*.xmf
        for f in "$out"/match_"${scene}"_np?/frame_*.h5; do split -b 16M "$f" "$f.part" && rm "$f"; done
      fi
    done
    ;;
  weak)
    /usr/bin/python3 jobs/studies/scaling.py --exe "$exe" --device cuda --threads "$threads" \
      --ranks "$ranks" --series weak --per-rank 4e6 --steps "$steps" --out "$out/weak_dambreak" "${prof[@]}" "${verlet[@]}"
    /usr/bin/python3 jobs/studies/scaling.py --exe "$exe" --device cuda --threads "$threads" \
      --scene pour --ranks "$ranks" --series weak --per-rank 1 --steps "$steps" --out "$out/weak_pour" "${prof[@]}"
    ;;
  strong)
    /usr/bin/python3 jobs/studies/scaling.py --exe "$exe" --device cuda --threads "$threads" \
      --ranks "$ranks" --series strong --total "${STRONG_TOTAL:-8e6,32e6}" --steps "$steps" --out "$out/strong" "${prof[@]}" "${verlet[@]}"
    ;;
  steady)
    /usr/bin/python3 jobs/studies/scaling.py --exe "$exe" --device cuda --threads "$threads" \
      --ranks "$ranks" --series weak --per-rank 4e6 --steps "${STEADY:-300,1500}" --out "$out/steady" "${prof[@]}" "${verlet[@]}"
    ;;
  *) echo "unknown part $part" ;;
  esac
done
echo "=== end ($(date -u +%T))"
(cd "$out" && find . -name '*.log' -o -name '*.csv' | tar czf logs.tar.gz -T - && find . \( -name '*.log' -o -name '*.csv' -o -name '*.toml' \) -delete)
