#!/usr/bin/env bash
# A run killed with SIGKILL at any moment resumes from its newest complete checkpoint and ends bit
# for bit where the uninterrupted run ends, on the same rank count (P8). The dam break (coarse, 0.3
# s, a checkpoint every 40 steps, frames every 0.05 s) runs once whole; then it is killed at random
# moments (seeded; the seed is printed) and once inside a checkpoint's write (KF_KILL_PUBLISHING:
# after its temporary file, before the rename), each time resumed with `--restart latest` (again
# and again until it finishes: a resumed run may be killed too), and its last frame compared with
# the whole run's (tests/checkpoint/same_state.py: every field, rows in id order). No .tmp may be
# left, at most checkpoint_keep checkpoints.
# Usage: kill_resume.sh KNITFLOW SCENE NP [MPIEXEC]   (KILL_RESUME_DEVICE=cuda: on the GPU)
set -uo pipefail
exe=$1 scene=$2 np=$3 mpiexec=${4:-}
here="$(cd "$(dirname "$0")" && pwd)"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export OMP_NUM_THREADS=1
# A Python with h5py (Debian's; a GPU machine's may be another first on PATH).
py=/usr/bin/python3
for p in python3 /usr/bin/python3; do
  if "$p" -c "import h5py" 2>/dev/null; then py=$p; break; fi
done
launch=("$exe")
[ "$np" -gt 1 ] && launch=("$mpiexec" -n "$np" --oversubscribe "$exe")
opts=(--device "${KILL_RESUME_DEVICE:-cpu}" --quiet --set fluid.spacing=0.02 --set simulation.end_time=0.3
      --set output.interval=0.05 --set output.checkpoint_steps=40 --set output.checkpoint_keep=2)
last=frame_000006.h5

start=$(date +%s.%N)
"${launch[@]}" run "$scene" "${opts[@]}" --output "$out/whole" || { echo "FAIL: the whole run"; exit 1; }
whole=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.3f", b - a }')
echo "whole run: ${whole} s"

seed=${KILL_RESUME_SEED:-$(date +%s)}
RANDOM=$seed
echo "seed $seed (KILL_RESUME_SEED=$seed reproduces the kill times)"
fail=0
for case in 1 2 3 publishing; do
  dir="$out/cut$case"
  if [ "$case" = publishing ]; then
    KF_KILL_PUBLISHING=3 "${launch[@]}" run "$scene" "${opts[@]}" --output "$dir" > "$dir.log" 2>&1
    echo "case publishing: killed in the third checkpoint's write (exit $?)"
    ls "$dir/checkpoints"
  else
    # A kill between 10% and 90% of the whole run's time.
    wait_s=$(awk -v w="$whole" -v r=$RANDOM 'BEGIN { printf "%.3f", w * (0.1 + 0.8 * r / 32767) }')
    setsid "${launch[@]}" run "$scene" "${opts[@]}" --output "$dir" > "$dir.log" 2>&1 &
    pid=$!
    sleep "$wait_s"
    # The whole session: mpiexec puts its ranks in process groups of their own, so killing the
    # group alone leaves ranks that go on writing (a .tmp appearing after the resume began).
    pkill -KILL -s "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
    for _ in $(seq 50); do pgrep -s "$pid" > /dev/null || break; sleep 0.1; done
    echo "case $case: killed after $wait_s s"
  fi
  at_kill=$(ls "$dir/checkpoints" 2>/dev/null | grep -v tmp | tail -1)
  for attempt in 1 2 3; do
    if "${launch[@]}" run "$scene" "${opts[@]}" --output "$dir" --restart latest \
        >> "$dir.log" 2>&1; then
      break
    fi
    # Killed before any state was written: start again.
    grep -q "no complete checkpoint or snapshot" "$dir.log" &&
      "${launch[@]}" run "$scene" "${opts[@]}" --output "$dir" >> "$dir.log" 2>&1 && break
  done
  if ! "$py" "$here/same_state.py" "$out/whole/$last" "$dir/$last"; then
    echo "FAIL case $case: the resumed run's last frame differs"; cat "$dir.log"; fail=1
  elif compgen -G "$dir/*.tmp" > /dev/null || compgen -G "$dir/checkpoints/*.tmp" > /dev/null; then
    echo "FAIL case $case: a .tmp was left"; fail=1
  elif [ "$(ls "$dir"/checkpoints | wc -l)" -gt 2 ]; then
    echo "FAIL case $case: more than checkpoint_keep checkpoints"; ls "$dir/checkpoints"; fail=1
  else
    echo "ok   case $case: resumed (newest checkpoint at the kill: ${at_kill:-none}) and ended bit for bit"
  fi
done
exit $fail
