"""Calibrated motion: learn each arm's cable effects and pre-compensate its commands.

- `base`: the one model interface; `modelfile`: the one file format with metadata.
- `physics_model`, `hybrid_model`, `lstm_model`: the three models; the physics model's effects come from
  `pegbt.sim2real.identify`, and recordings are read and written by `pegbt.physics.recording`.
- `compensation`: the reference paper's Alg. 1, per 10 ms step or per goal, within the joint limits.
- `evaluation`: held-out joint RMSE and tool-tip error.
- `task`: the peg-transfer joints calibration must cover; `collect`: a recording from a live arm;
  `closed_loop`: collect from the simulator and measure compensated tip error at the transfer waypoints.

Torch loads only with the learned models: `from pegbt.calibration.compensation import Compensator`.
"""
