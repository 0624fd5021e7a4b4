"""Shared builders for the sim2real tests: commands and recordings with known physics."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording
from pegbt.sim2real.synth import smooth_commands

SIGMA = 0.002


def commands(seed: int, seconds: float = 20.0, rate_hz: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    return t, smooth_commands(rng, t, rng.uniform(0.8, 1.6, 6))


def recording_with(
    effects: list[Effect], seed: int = 0, noise: str = "white", sigma: float = SIGMA, seconds: float = 20.0
) -> Recording:
    """A 100 Hz stream whose physical joints follow `effects`, plus white or AR(1) (ρ = 0.9) noise."""
    t, q_cmd = commands(seed, seconds)
    rng = np.random.default_rng(seed + 1000)
    e = rng.standard_normal(q_cmd.shape)
    if noise == "ar1":
        for n in range(1, len(e)):
            e[n] = 0.9 * e[n - 1] + np.sqrt(1 - 0.81) * e[n]
    q_phy = ArmPhysics(effects).simulate(q_cmd, t) + sigma * e
    return Recording(Path(f"<test {seed}>"), q_cmd, q_phy, t)
