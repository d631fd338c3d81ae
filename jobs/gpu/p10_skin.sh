B=.devrt/bin; off="--set output.enabled=false"
for r in 1 2; do for sk in 0.1 0.15 0.2; do echo "== skin $sk round $r"; $B/bench_gpu --device cuda --cases pour --lists verlet --set solver.neighbour_skin=$sk 2>&1 | grep -iE "pour" | tail -2; done; done
for sk in 0.1 0.15 0.2; do $B/knitflow run scenes/pour.toml --device cuda $off --set solver.neighbour_skin=$sk --output $OUT/o > $OUT/l 2>&1; echo "whole skin $sk: $(grep ^done $OUT/l)"; grep -E "^(particles|coupling|neighbour)" $OUT/l | cut -c1-140; done; rm -rf $OUT/o $OUT/l
