#!/usr/bin/env bash
# Every scene in scenes/ runs through the app on 2 ranks as it does on one (P5), snapshots
# included: a few steps of each, on 1 rank and under mpiexec -n 2, and the last frames must hold
# the same particles of every phase (ids, and the yarn's rows), each written once, with the
# owning rank's field naming both ranks; a restart on 2 ranks from the first frame then runs to
# the same end, and the 2-rank run's snapshots draw as pictures on 2 ranks (P6). The physics of
# the split is checked particle by particle in test_distributed_*_mpi; this catches what only the app's path meets (the writer's
# checks that the ranks agree, a rank owning none of a phase, the scenes' own settings).
# Debian's python3 (/usr/bin: h5py and numpy come as its packages, scripts/install-deps.sh).
# Usage: scenes_np2.sh KNITFLOW SCENES_DIR MPIEXEC
set -uo pipefail
exe=$1 scenes=$2 mpiexec=$3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail=0
for scene in "$scenes"/*.toml; do
  name=$(basename "$scene" .toml)
  # 2 ms of simulated time (40-200 steps), a frame each millisecond.
  args=(run "$scene" --device cpu --quiet --set simulation.end_time=0.002
        --set output.interval=0.001)
  if ! OMP_NUM_THREADS=1 timeout 300 "$exe" "${args[@]}" --output "$out/$name.1" \
       > "$out/$name.1.log" 2>&1; then
    echo "FAIL $name: 1 rank"; cat "$out/$name.1.log"; fail=1; continue
  fi
  if ! OMP_NUM_THREADS=1 timeout 300 "$mpiexec" -n 2 --oversubscribe "$exe" "${args[@]}" \
       --output "$out/$name.2" > "$out/$name.2.log" 2>&1; then
    echo "FAIL $name: 2 ranks"; cat "$out/$name.2.log"; fail=1; continue
  fi
  if ! /usr/bin/python3 - "$out/$name.1" "$out/$name.2" <<'EOF'
import glob, sys
import h5py, numpy as np
one, two = (sorted(glob.glob(d + "/frame_*.h5")) for d in sys.argv[1:3])
assert len(one) == len(two) >= 2, f"frames: {len(one)} on 1 rank, {len(two)} on 2"
ranks = set()
with h5py.File(one[-1], "r") as a, h5py.File(two[-1], "r") as b:
    assert set(a) == set(b), f"phases {sorted(a)} on 1 rank, {sorted(b)} on 2"
    for phase in a:
        if "id" in a[phase]:
            ia, ib = np.sort(a[phase]["id"][:]), np.sort(b[phase]["id"][:])
            assert ia.shape == ib.shape and (ia == ib).all(), \
                f"{phase}: {ia.size} ids on 1 rank, {ib.size} on 2 (or others)"
            ranks |= set(np.unique(b[phase]["rank"][:]).tolist())
        else:
            na, nb = (f[phase]["position"].shape[0] for f in (a, b))
            assert na == nb, f"{phase}: {na} rows on 1 rank, {nb} on 2"
assert ranks == {0, 1}, f"owning ranks written: {sorted(ranks)}"
EOF
  then
    echo "FAIL $name: the last frames differ"; fail=1; continue
  fi
  # And the app's restart on 2 ranks from the 2-rank run's first frame to the same end (the
  # continuation is compared particle by particle in test_distributed_*_mpi).
  if ! OMP_NUM_THREADS=1 timeout 300 "$mpiexec" -n 2 --oversubscribe "$exe" "${args[@]}" \
       --restart "$out/$name.2/frame_000001.h5" --output "$out/$name.r" > "$out/$name.r.log" 2>&1 \
     || [ ! -f "$out/$name.r/$(basename "$(ls "$out/$name.2"/frame_*.h5 | tail -1)")" ]; then
    echo "FAIL $name: restart on 2 ranks"; cat "$out/$name.r.log"; fail=1; continue
  fi
  # And its pictures, the frames shared out over 2 ranks: one PNG a snapshot. The surface's grid
  # at 2 spacings, not 0.5: a pixel of the pour's 64 x 48 is ~5 of them (25 mm at 1.9 m), and
  # the finer grid's field was 15 of the pour's 22 s a frame through llvmpipe (11 s at 2; the
  # picture within 4 levels, in 4 pixels).
  look=(--width 64 --height 48 --set render.surface_cell=2)
  if ! timeout 300 "$mpiexec" -n 2 --oversubscribe "$exe" render "$out/$name.2" "${look[@]}" \
       --quiet > "$out/$name.png.log" 2>&1 \
     || [ "$(ls "$out/$name.2"/render/frame_*.png | wc -l)" != "$(ls "$out/$name.2"/frame_*.h5 | wc -l)" ]; then
    echo "FAIL $name: render on 2 ranks"; cat "$out/$name.png.log"; fail=1; continue
  fi
  # And the last frame drawn in two parts of space composited (binary swap: by depth, the
  # volumetric yarns by "over" in the parts' order): the picture one rank draws whole, every
  # channel within 1 level (the yarns blended in half floats in parts, in 8 bits whole;
  # tests/mpi/test_render_composite_mpi measures it; the opaque scene alone is byte for byte)
  # but in 1 pixel in 1,000: where a part's face cuts two slices whose order by their centres
  # (the whole frame's) is not the order along the line of sight (the parts'), here the garment's
  # silhouette at its cut (1 pixel of 3,072, 45 levels off).
  last=$(ls "$out/$name.2"/frame_*.h5 | tail -1 | sed -E 's/.*frame_0*([0-9]+)\.h5/\1/')
  for n in 1 2; do
    timeout 300 "$mpiexec" -n $n --oversubscribe "$exe" render "$out/$name.2" "${look[@]}" \
      --quiet --frames "$last:$last:1" --split space --out "$out/$name.space$n" \
      > "$out/$name.space$n.log" 2>&1 || { echo "FAIL $name: --split space on $n rank(s)"; cat "$out/$name.space$n.log"; fail=1; continue 2; }
  done
  if ! /usr/bin/python3 - "$out/$name.space1"/frame_*.png "$out/$name.space2"/frame_*.png <<'EOF'
import sys
import matplotlib.image as mpimg
import numpy as np
a, b = (np.rint(255 * mpimg.imread(p)).astype(int) for p in sys.argv[1:3])
assert a.shape == b.shape, f"{a.shape} against {b.shape}"
off = np.abs(a - b).max(axis=2)
beyond = int((off > 1).sum())
assert beyond <= off.size // 1000, f"{beyond} pixels beyond 1 level of the picture drawn whole"
EOF
  then
    echo "FAIL $name: the composited picture is not the one drawn whole"; fail=1; continue
  fi
  echo "ok   $name"
done
exit $fail
