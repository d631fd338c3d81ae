# The small scenes the sanitizer runs use (sourced by jobs/gpu/p5_sanitizer.sh on the GPU and
# scripts/test-valgrind.sh on the CPU): each scene's file and overrides, without the device, the
# output or the step count. Small and short, each reaching the effect it is there for.
# The dam break with "verlet" lists, re-partitioned every 20 steps (its first at step 20).
san_dambreak=(scenes/dambreak.toml --set fluid.spacing=0.02 --set 'solver.neighbour_list="verlet"'
  --set parallel.imbalance=1.0 --set parallel.payback=false --set parallel.check_every=20)
# The same with particle shifting (the fluid's option with a per-step scratch of its own, sized to
# the fluid and its ghosts: the CPU's copy check found its growth copying the ghosts' slots).
san_shifting=("${san_dambreak[@]}" --set 'solver.shifting="fickian"')
# The stream starts just above the knit, so that the coupling (contacts, absorption, the
# coupling's ghosts) runs within the steps: from the scene's height it meets the knit after ~400
# steps (before 2026-12-07, fourth session, the GPU job's pour never reached it).
san_pour=(scenes/pour.toml --set fluid.spacing=0.012 --set knit.piece.0.wales=24
  --set knit.piece.0.courses=24 --set 'fluid.block.0.min=[-0.04,-0.04,0.535]'
  --set 'fluid.block.0.max=[0.04,0.04,0.65]')
# The strip's foot starts 1 cm deep in the pool (the scene lowers it there over ~220 steps): the
# conserving absorption runs from the first step (80 contacts, 42 wet points by step 21).
san_wicking=(scenes/wicking.toml --set fluid.spacing=0.01 --set knit.piece.0.courses=32
  --set 'knit.piece.0.center=[0,0,0.10]' --set 'knit.pin.0.min=[-0.02,-0.01,0.175]'
  --set 'knit.pin.0.max=[0.02,0.01,0.185]' --set 'knit.pin.1.min=[-0.02,-0.01,0.015]'
  --set 'knit.pin.1.max=[0.02,0.01,0.025]')
san_drape=(scenes/drape.toml --set knit.piece.0.wales=32 --set knit.piece.0.courses=32)
san_garment=(scenes/garment.toml)
