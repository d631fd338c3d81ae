#!/usr/bin/env bash
# The dam break split over N MPI ranks on one machine (CPU backend, one OpenMP thread a rank),
# then the same on one rank, and the two last snapshots compared particle by particle: they are
# the same bit for bit (docs/ARCHITECTURE.md, Distribution). Snapshots of the split run carry a
# `rank` field: colour by it in ParaView (out/dambreak_ranks/snapshots.xmf).
#   jobs/mpi/dambreak_ranks.sh [N] [extra knitflow options...]
set -euo pipefail
cd "$(dirname "$0")/../.."
n=${1:-2}
shift || true
exe=build/cpu/apps/knitflow
[ -x "$exe" ] || { cmake --preset cpu >/dev/null && cmake --build --preset cpu -j"$(nproc)" --target knitflow; }
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
common=(--set fluid.spacing=0.01 --set simulation.end_time=0.2 --set output.interval=0.05 "$@")
OMP_NUM_THREADS=1 mpiexec -n "$n" --oversubscribe "$exe" run scenes/dambreak.toml --threads 1 \
  --output out/dambreak_ranks "${common[@]}"
"$exe" run scenes/dambreak.toml --threads 1 --output out/dambreak_one "${common[@]}" -q
last=$(ls out/dambreak_one/frame_*.h5 | tail -1)
python3 - "$last" "out/dambreak_ranks/$(basename "$last")" <<'PY'
import sys, h5py, numpy as np
def load(p):
    f = h5py.File(p, "r")["fluid"]
    o = np.argsort(f["id"][:])
    return {k: f[k][:][o] for k in ("id", "position", "velocity", "density")}, f
a, _ = load(sys.argv[1]); b, g = load(sys.argv[2])
same = all(np.array_equal(a[k], b[k]) for k in a)
print(f"{len(a['id'])} particles; ranks own", np.bincount(g["rank"][:]).tolist(),
      "; identical to one rank" if same else "; DIFFERENT from one rank")
sys.exit(0 if same else 1)
PY
