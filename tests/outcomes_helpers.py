"""A stand-in for the phase simulator whose outcome rates are known functions of the world effects, so the
fit's statistics can be checked without simulating arms."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell
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


Tasks = Sequence[tuple[tuple[WorldEffects, ...], str, str, int]]
Rate = Callable[[WorldEffects, str, str], float]


def rate_mapper(rate: Rate, phase: str, stream: int = 99) -> Callable[[Tasks], list[list[TransferResult]]]:
    """A mapper placing each transfer with probability `rate(world, variant, condition)`, a failure being
    at `phase`: one uniform draw per seed (stream `stream`) shared by every world, as common random numbers."""

    def mapper(tasks: Tasks) -> list[list[TransferResult]]:
        out = []
        for worlds, variant, condition, seed in tasks:
            u = np.random.default_rng([seed, stream]).random()
            placed = [bool(u < rate(effects, variant, condition)) for effects in worlds]
            out.append([TransferResult(p, None if p else phase, 4.0) for p in placed])
        return out

    return mapper


fake_mapper = rate_mapper(lift_success, "lift")


def grip_or_bend(grip_lifts: float) -> Rate:
    """`lift_success` (a bending peg), where a yielding grip of any size lifts `grip_lifts` of uncalibrated
    blocks: two kinds that fit the same lift, apart by how many they lift."""

    def rate(world: WorldEffects, variant: str, condition: str) -> float:
        if condition == "uncalibrated" and world.values("grip_compliance")["displacement"] > 0:
            return grip_lifts
        return lift_success(world, variant, condition)

    return rate


def real_counts(effects: WorldEffects, variant: str, condition: str, attempted: int, seed: int) -> int:
    """What a robot in that world would place of `attempted` transfers."""
    return int(
        np.random.default_rng([seed, 5]).binomial(attempted, lift_success(effects, variant, condition))
    )


def failing_at(phase: str, variant: str, condition: str, attempted: int, placed: int) -> Cell:
    """A cell as tick logs report it, every failure at `phase` (a stand-in mapper's one phase)."""
    return Cell(variant, condition, attempted, placed, failures={phase: attempted - placed})


def logged_cell(effects: WorldEffects, variant: str, condition: str, attempted: int, seed: int) -> Cell:
    """A cell as a robot in that world would log it: `real_counts` placed, the rest failed at the lift
    (the phase every failure of `fake_mapper` is at)."""
    placed = real_counts(effects, variant, condition, attempted, seed)
    return failing_at("lift", variant, condition, attempted, placed)


def chamfer_placed(effects: WorldEffects, variant: str, condition: str) -> float:
    """A stand-in chamfer: wider capture places more uncalibrated lowerings, 7.7 % at the default radius
    (2 mm) to 12 % from 3.2 mm, the change chamfer capture makes at the bench's 1,104 real transfers; a
    calibrated arm places every block."""
    if condition != "uncalibrated":
        return 1.0
    radius = effects.values("chamfer_capture")["capture_radius"]
    return 0.077 + 0.043 * min(1.0, max(0.0, (radius - 0.002) / 0.0012))


# `fake_mapper` with `chamfer_placed` for its rates: a failure is at the lowering
chamfer_mapper = rate_mapper(chamfer_placed, "lower")
