"""A trial's transfers in order on one world, as pegbt's trees run them when one arm moves at a time.

The phase simulator alone (`phasesim.simulate_transfer`) gives each transfer a world where only its own
block has moved, and its recoveries go after that block. In a whole trial a block an earlier transfer lost
stays where it fell, and a recovery picks the loose block nearest its pick peg, whichever that is
(`SelectGrasp` with `dropped`, `pegbt/behaviours/actions/grasping.py`); a way back finds its block where
the way out left it, or finds no block (`sense`), and its recoveries then fetch a loose one. The
unilateral and handover trees move one block at a time, so one world played in order is their trial;
bilateral's two arms carry at once, which a world played in order does not reproduce (`in_order`).

Seed `s` of a cell is transfer `s mod n` of the trial on layout `s // n` (`n` transfers a trial), so a
simulated transfer stays a function of its world, variant, condition and seed, and consecutive seeds share
one trial, simulated once for all of them (`simulate_trial`).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache, partial

import numpy as np

from pegbt.errors import PegbtError
from pegbt.pegboard import N_PEGS
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import (
    REGRASPS,
    Replay,
    TransferResult,
    arms_at_once,
    carry_out,
    transfers,
)
from pegbt.workcell import ORDERS_FILE
from pegbt.yamlfile import read_settings_file


def in_order(variant: str) -> bool:
    """Whether `variant`'s trial is simulated in order: its transfers run one at a time."""
    return arms_at_once(variant) == 1


def trial_of(variant: str, seed: int) -> tuple[int, int]:
    """The layout of the trial seed `seed` stands for, and which of its transfers it is."""
    return divmod(seed, len(transfers(variant)))


@cache
def strays(variant: str) -> tuple[tuple[int, ...], ...]:
    """Per transfer of `variant`, the pegs its pick may fetch a lost block from once none lies loose: the
    handover's giver looks on peg 6, under the meeting point, where a block dropped there falls (`strays`
    in `trees/shared/orders.yaml`, passed on by `trees/shared/handover.yaml` only)."""
    if variant != "handover":
        return ((),) * len(transfers(variant))
    items = read_settings_file(ORDERS_FILE).section("lists")["reference"].sequence()
    listed = [item.get("strays") for item in items]
    return tuple(
        () if pegs is None else tuple(peg.integer(low=0, high=N_PEGS - 1) for peg in pegs.sequence())
        for pegs in listed
    )


def chosen_block(world: World, peg: int, dropped: bool, strays: tuple[int, ...] = ()) -> int | None:
    """The block a pick from `peg` goes after, as `select_grasp` chooses it from what it sees: the top one
    on `peg`, else, once the transfer has lost its block (`dropped`), the loose block (on the board, or on
    another block) nearest to the peg, else the top one on a peg of `strays`; None when there is none."""
    free = [b for b in world.blocks if not b.lost and not b.grips]
    on_peg = [b for b in free if b.peg == peg]
    if on_peg:
        return min(on_peg, key=lambda b: float(b.pose[2, 3])).index  # board z points down: the top one
    if not dropped:
        return None
    surface, height = world.cell.board.surface_z, world.cell.block.height
    loose = [b for b in free if b.peg is None or b.pose[2, 3] < surface - height / 2]
    target = world.cell.pegs.positions[peg]
    nearest = min(loose, key=lambda b: float(np.linalg.norm(b.pose[:2, 3] - target)), default=None)
    if nearest is not None:
        return nearest.index
    return next((found for stray in strays if (found := chosen_block(world, stray, False)) is not None), None)


def simulate_trial(
    worlds: Sequence[WorldEffects],
    variant: str,
    condition: str,
    layout: int,
    count: int,
    attempts: int = 1 + REGRASPS,
    registered: bool = False,
) -> list[list[TransferResult]]:
    """The first `count` transfers of `variant`'s trial on layout `layout`, in order, in each of `worlds`
    (per transfer, per world). The worlds share each transfer's perception noise and replay the arm's
    motion where it is the same (`phasesim.Replay`); a motion the planner refuses is a transfer failed
    where it started, and the trial goes on."""
    states = [World(layout, effects=effects) for effects in worlds]
    results = []
    for index in range(count):
        replay, row = Replay(), []
        for world in states:
            rng = np.random.default_rng([layout, index, 7])
            try:
                pick = partial(chosen_block, strays=strays(variant)[index])
                result = carry_out(world, variant, condition, index, replay, attempts, registered, rng, pick)
            except PegbtError:
                result = TransferResult(False, "reach", 0.0)
            row.append(result)
        results.append(row)
    return results
