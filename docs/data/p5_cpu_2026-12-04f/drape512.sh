#!/bin/bash
# usage: [RANKS="1 2 4 8"] drape512.sh EXE... ; runs each at 1, 2, 4 ranks (or RANKS), alternated
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cd /work/main
for n in ${RANKS:-1 2 4}; do
  for exe in "$@"; do
    echo "== $n $exe"
    s=$(date +%s.%N)
    mpiexec --oversubscribe -n $n $exe run scenes/drape.toml --set knit.piece.0.wales=512 --set knit.piece.0.courses=512 --set knit.piece.0.width=2.8 --set knit.piece.0.height=2.8 --set "domain.min=[-1.5,-1.5,0]" --set "domain.max=[1.5,1.5,1]" --set solver.max_steps=1 --set output.enabled=false --device cpu --threads 1 2>&1 | grep -E "^memory|^knit:|rror"
    e=$(date +%s.%N)
    echo "wall $(echo "$e - $s" | bc)"
  done
done
