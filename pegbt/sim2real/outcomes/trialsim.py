"""A unilateral or handover trial's transfers in order on one world, as pegbt's trees run them.

The phase simulator alone (`phasesim.simulate_transfer`) gives each transfer a world where only its own
block has moved, and its recoveries go after that block. In a whole trial a block an earlier transfer lost
stays where it fell, and a recovery picks the loose block nearest its pick peg, whichever that is
(`SelectGrasp` with `dropped`, `pegbt/behaviours/actions/grasping.py`); a way back finds its block where
the way out left it, or finds no block (`sense`), and its recoveries then fetch a loose one. The unilateral
tree moves one block at a time, so one world played in order is its trial (`in_order`). So do the handover's
trees (`trees/handover.yaml`): the giver picks (from the board, or a `strays` peg under the meeting point,
once it lost its block), the receiver takes the block again after a miss and fetches one that slipped
(`exchange.hand_over`), and it comes to the meeting from its last placing, or from home after a
handover that failed (the trees park it). Bilateral's two arms carry at
once, which one world played in order does not reproduce: it stays alone.

Seed `s` of a cell is transfer `s mod n` of the trial on layout `s // n` (`n` transfers a trial), so a
simulated transfer stays a function of its world, variant, condition and seed, and consecutive seeds share
one trial, simulated once for all of them (`simulate_trial`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pegbt.errors import PegbtError
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.bench import Replay
from pegbt.sim2real.outcomes.phasesim import REGRASPS, carry_out
from pegbt.sim2real.outcomes.transfer_order import transfers
from pegbt.sim2real.outcomes.transfer_result import TransferResult


def in_order(variant: str) -> bool:
    """Whether `variant`'s trial is simulated in order: the unilateral and the handover ones (see the
    module's docstring)."""
    return variant in ("unilateral", "handover")


def trial_of(variant: str, seed: int) -> tuple[int, int]:
    """The layout of the trial seed `seed` stands for, and which of its transfers it is."""
    return divmod(seed, len(transfers(variant)))


def chosen_block(world: World, peg: int, dropped: bool, strays: Sequence[int] = ()) -> int | None:
    """The block a pick from `peg` goes after, as `select_grasp` chooses it from what it sees: the top one
    on `peg`, else, once the transfer has lost its block (`dropped`), the loose block (on the board, or on
    another block) nearest to the peg, else the top one on the first of `strays` that holds one (a
    handover's block dropped at the meeting point falls onto peg 6); None when there is none."""
    free = [b for b in world.blocks if not b.lost and not b.grips]

    def top(on: int) -> int | None:
        on_peg = [b for b in free if b.peg == on]
        return min(on_peg, key=lambda b: float(b.pose[2, 3])).index if on_peg else None  # board z: down

    found = top(peg)
    if found is not None or not dropped:
        return found
    surface, height = world.cell.board.surface_z, world.cell.block.height
    loose = [b for b in free if b.peg is None or b.pose[2, 3] < surface - height / 2]
    target = world.cell.pegs.positions[peg]
    nearest = min(loose, key=lambda b: float(np.linalg.norm(b.pose[:2, 3] - target)), default=None)
    if nearest is not None:
        return nearest.index
    return next((block for block in map(top, strays) if block is not None), None)


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
    motion where it is the same (`bench.Replay`); a motion the planner refuses is a transfer failed
    where it started, and the trial goes on."""
    states = [World(layout, effects=effects) for effects in worlds]
    results: list[list[TransferResult]] = []
    for index in range(count):
        replay, row = Replay(), []
        for at, world in enumerate(states):
            rng = np.random.default_rng([layout, index, 7])
            parked = bool(results) and not results[-1][at].over_goal  # the last handover failed
            try:
                result = carry_out(
                    world, variant, condition, index, replay, attempts, registered, rng, chosen_block, parked
                )
            except PegbtError:
                result = TransferResult(False, "reach", 0.0)
            row.append(result)
        results.append(row)
    return results
