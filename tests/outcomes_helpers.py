"""A stand-in for the phase simulator whose outcome rates are known functions of the world effects, so the
fit's statistics can be checked without simulating arms."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import TransferResult

BASE = {"unilateral": 0.05, "bilateral": 0.10, "handover": 0.02}  # the default world's lift success
REACH = {"unilateral": 1.0, "bilateral": 1.2, "handover": 0.6}  # how much a bending peg helps each variant


def lift_success(effects: WorldEffects, variant: str, condition: str) -> float:
    """A bending peg raises the uncalibrated lift's success in proportion to its deflection; a calibrated
    arm lifts every time; chamfers help only the lowering, which never fails here."""
    if condition != "uncalibrated":
        return 1.0
    deflection = effects.values("peg_compliance")["deflection"]
    return min(1.0, BASE[variant] + REACH[variant] * deflection / 0.003 * 0.5)


def fake_mapper(
    tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]],
) -> list[list[TransferResult]]:
    out = []
    for worlds, variant, condition, seed in tasks:
        u = np.random.default_rng([seed, 99]).random()
        placed = [bool(u < lift_success(effects, variant, condition)) for effects in worlds]
        out.append([TransferResult(p, None if p else "lift", 4.0) for p in placed])
    return out


def real_counts(effects: WorldEffects, variant: str, condition: str, attempted: int, seed: int) -> int:
    """What a robot in that world would place of `attempted` transfers."""
    return int(
        np.random.default_rng([seed, 5]).binomial(attempted, lift_success(effects, variant, condition))
    )


def chamfer_placed(effects: WorldEffects, variant: str, condition: str) -> float:
    """A stand-in chamfer: wider capture places more uncalibrated lowerings, 7.7 % at the default radius
    (2 mm) to 12 % from 3.2 mm, the change chamfer capture makes at the bench's 1,104 real transfers; a
    calibrated arm places every block."""
    if condition != "uncalibrated":
        return 1.0
    radius = effects.values("chamfer_capture")["capture_radius"]
    return 0.077 + 0.043 * min(1.0, max(0.0, (radius - 0.002) / 0.0012))


def chamfer_mapper(
    tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]],
) -> list[list[TransferResult]]:
    """`fake_mapper` with `chamfer_placed` for its rates: a failure is at the lowering."""
    out = []
    for worlds, variant, condition, seed in tasks:
        u = np.random.default_rng([seed, 99]).random()
        placed = [bool(u < chamfer_placed(effects, variant, condition)) for effects in worlds]
        out.append([TransferResult(p, None if p else "lower", 4.0) for p in placed])
    return out
