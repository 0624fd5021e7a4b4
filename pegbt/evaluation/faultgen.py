"""A fault plan per seed, in the simulator's YAML format: the faults the paper's task meets in practice.

Each trial gets one missed grasp (a grasp attempt, drawn from the first twelve, that would have held),
slips at a rate of about one per trial's worth of holding, and depth-noise bursts on about one capture
in five. The plan is drawn from the seed alone, so a faulty trial is as reproducible as a clean one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

SLIP_RATE = 0.04  # per second a block is held: a 12-transfer trial holds blocks ≈20–30 s
BURST_PROBABILITY = 0.2  # per capture
GRASP_ATTEMPTS = 12  # the missed grasp is one of the first this many
STREAM = 0xFA017  # keeps the plan's draws apart from every other use of the seed


def fault_plan(seed: int) -> dict[str, Any]:
    """The fault plan of trial `seed` (a mapping for `pegbt.sim.fault_plan.FaultPlan`'s YAML)."""
    rng = np.random.default_rng([seed, STREAM])
    return {
        "seed": seed,
        "world": {"miss_attempts": [int(rng.integers(GRASP_ATTEMPTS))], "slip_rate": SLIP_RATE},
        "camera": {"burst_probability": BURST_PROBABILITY},
    }


def write_fault_plan(directory: Path, seed: int) -> Path:
    """Write trial `seed`'s plan as `DIRECTORY/faults-SEED.yaml`; returns its path."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"faults-{seed}.yaml"
    path.write_text(yaml.safe_dump(fault_plan(seed), sort_keys=False), encoding="utf-8")
    return path
