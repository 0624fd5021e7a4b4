"""`pegbt sim2real outcomes`: where trial outcomes on the robot and on the simulator disagree, which world
effects explain it, the fitted world, and the proof on cells the fit never saw.

One level above the joint-level tool (`pegbt.sim2real`): its data are transfers attempted and placed per
task variant × condition (and per phase of a failure, when tick logs say), its simulator the world's
contact physics (`pegbt.sim.world_effects`), never the arm's physics, which stays as fitted on the
real recordings (`dvrk-real`).
"""
