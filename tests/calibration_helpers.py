"""Synthetic recordings for the calibration tests: smooth random set-points through a known ArmPhysics."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pegbt.calibration.collect import random_setpoints
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording, RecordingWriter

TRUTH = [
    Effect("offset", "q1", {"value": 0.004}),
    Effect("offset", "q4", {"value": 0.2}),
    Effect("offset", "q5", {"value": -0.08}),
    Effect("scale", "q6", {"value": 0.9}),
    Effect("coupling", "q5", {"source": "q6", "k": 0.15}),
    Effect("coupling", "q6", {"source": "q5", "k": 0.2}),
    Effect("backlash", "q5", {"half_width": 0.04}),
    Effect("backlash", "q6", {"half_width": 0.06}),
]


def set_points(n: int, seed: int = 0, arm: str = "PSM1", margin: float = 0.4) -> np.ndarray:
    """n smooth random set-points inside the middle `margin` of the joint ranges, as `calibrate collect`
    draws them (each joint sweeps back and forth, like the dVRK recordings)."""
    limits = arm_settings(arm)
    centre, half = (limits.lower + limits.upper) / 2, (limits.upper - limits.lower) / 2 * margin
    return random_setpoints(centre - half, centre + half, n, np.random.default_rng(seed))


def synthetic(n: int = 400, seed: int = 0, noise: float = 0.0, arm: str = "PSM1") -> Recording:
    """A recording of the TRUTH arm; `noise` is the measurement noise in rad (a hundredth of it in m on q3)."""
    q_cmd = set_points(n, seed, arm)
    sigma = noise * np.array([1, 1, 0.01, 1, 1, 1])
    q_phy = (
        ArmPhysics(TRUTH).simulate(q_cmd) + np.random.default_rng(seed + 1).normal(0, 1, q_cmd.shape) * sigma
    )
    return Recording(Path(f"<synthetic {arm}>"), q_cmd, q_phy, None, arm)


def write(recording: Recording, folder: Path) -> Path:
    writer = RecordingWriter(folder, recording.arm or "PSM1")
    for n, (q_cmd, q_phy) in enumerate(zip(recording.q_cmd, recording.q_phy)):
        writer.add(q_cmd, q_phy, 0.5 * n)
    return writer.close()
