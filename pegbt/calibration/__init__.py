"""Calibrated motion: learn each arm's cable effects and pre-compensate its commands.

- `recording`: the dataset layout (q_cmd.npy, q_phy.npy, t_stamp.npy) and its writer.
- `base`: the one model interface; `modelfile`: the one file format with metadata.
- `physics_model`, `hybrid_model`, `lstm_model`: the three models; `identify`: where effects come from.
- `compensation`: the reference paper's Alg. 1, per 10 ms step or per goal, within the joint limits.
- `evaluation`: held-out joint RMSE and tool-tip error.

Torch loads only with the learned models: `from pegbt.calibration.compensation import Compensator`.
"""
