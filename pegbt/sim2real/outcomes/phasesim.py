"""One transfer's phases simulated directly on the world: no zenoh, no tree, no camera (the fit's simulator,
many transfers a second).

An arm with the fitted cable physics (`dvrk-real`, `pegbt.sim.arm.SimArm`) plays the commands the
executive's `ArmMotion` would send under the condition (rest-to-rest cubics as planned, or pre-compensated
by the simulator's calibration models, or the optimised plan), and each control tick the world sees the
tool where the physical joints put it, as `pegbt.sim.scene.Scene.update` does: descend onto the grasp,
close, lift off the peg, carry, lower onto the goal peg, open. What perception would have seen is the
block's pose with its noise (`attempt.look_sd`: pegbt's perception's own, and a world's
`perception_noise`), displaced as the camera's world effects displace what it sees (`attempt.seen_point`);
the arms stand where the world's registration offset puts them (`World.arm_to_board`). The phase of a failure is read from the
world's events here (this is the simulator's side, where the truth is known).

This module is the entry: a transfer of a trial from its world, variant, condition and seed, set up as the
trees set it up. The rest, one job each: `transfer_order` (which arm carries which block, in the trees'
order), `bench` (one arm in one world, ticked at the control period, replayed across worlds), `attempt`
(one pick and carry), `trying` (a transfer's attempts, recovering as the trees do), `exchange` (a
handover's receiver taking, carrying and placing the block, and a handover's seconds in a trial) and
`transfer_result` (what is said of a transfer).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from pegbt.behaviours.resources.skills import SIMULATOR_CALIBRATION, Skills
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.bench import Replay
from pegbt.sim2real.outcomes.paperpairs import action_partner
from pegbt.sim2real.outcomes.transfer_order import moved_out, transfers
from pegbt.sim2real.outcomes.transfer_result import TransferResult
from pegbt.sim2real.outcomes.trying import Pick, Trying
from pegbt.workcell import transfer_strays

REGRASPS = 3  # recoveries before a transfer is given up (`trees/shared/one_transfer.yaml`)


@cache
def _skills(condition: str, variant: str = "") -> Skills:
    """The skills a trial of `variant` runs with (a lone arm's approach passes lower over the pegs)."""
    return Skills(condition, calibration=SIMULATOR_CALIBRATION, variant=variant)


def simulate_transfer(
    effects: WorldEffects,
    variant: str,
    condition: str,
    seed: int,
    replay: Replay | None = None,
    index: int | None = None,
    attempts: int = 1 + REGRASPS,
    registered: bool = False,
) -> TransferResult:
    """Transfer number `index` of `variant`'s transfers (by default `seed`, cycling), on a world of layout
    `seed` (a trial's transfers, one for one, with the same `seed` and each `index`), `attempts` in all;
    `registered`: each uncalibrated arm registered to the camera as the paper's were, with itself
    (`registration`).
    A transfer on the way back first simulates the outward transfer of its block: if that one was not
    placed, the way back finds its start peg empty and fails at `sense`, as a trial's tick log says (the
    recovery fetches strays only for a block the transfer itself lost). Under the paper's protocol
    (`registered`) a bilateral way back also needs its action pair's other block placed, or the pair is
    skipped (`paperpairs`). `replay`: the arm's motion in other worlds of this same transfer (variant,
    condition, seed), to reuse where it is the same."""
    replay = Replay() if replay is None else replay
    order = transfers(variant)
    index = seed % len(order) if index is None else index
    if index >= len(order) // 2:
        partner = action_partner(variant, index) if registered else None
        for back in (index,) if partner is None else (index, partner):
            start_peg = order[back][1]
            outward = next(i for i, (_, _, goal) in enumerate(order[: len(order) // 2]) if goal == start_peg)
            there = _transfer(effects, variant, condition, seed, outward, replay, attempts, registered)
            if not there.succeeded:
                return TransferResult(False, "sense", there.seconds, skipped=True)
    return _transfer(effects, variant, condition, seed, index, replay, attempts, registered)


def _transfer(
    effects: WorldEffects,
    variant: str,
    condition: str,
    seed: int,
    index: int,
    replay: Replay,
    attempts: int,
    registered: bool = False,
) -> TransferResult:
    """Transfer `index` of `variant`'s transfers alone on a world of layout `seed` (on the way back every
    block starts where its outward transfer placed it), its recoveries going after its own block."""
    world = World(seed, effects=effects)
    if index >= len(transfers(variant)) // 2:
        moved_out(world, transfers(variant))
    rng = np.random.default_rng([seed, 7])
    return carry_out(world, variant, condition, index, replay, attempts, registered, rng)


def carry_out(
    world: World,
    variant: str,
    condition: str,
    index: int,
    replay: Replay,
    attempts: int,
    registered: bool,
    rng: np.random.Generator,
    pick: Pick | None = None,
    receiver_parked: bool = False,
) -> TransferResult:
    """Transfer `index` of `variant`'s transfers on `world` as it lies: the grasp the executive would
    choose for the block perception would see, and the motions it would send, picked and carried again
    after a failure, `attempts` in all (`trees/shared/one_transfer.yaml` recovers `REGRASPS` times, from
    wherever the block fell); a grasp the planning refuses before the arm moves is sensed and planned again
    without counting. Each attempt goes after the block `pick` names (none found: a failure at `sense`,
    and the next attempt looks again); without `pick`, after the block on the pick peg wherever it falls.
    The arm's cables carry the history the tree gives them: the arm's first transfer of each half starts
    from the home pose the trees park it at before each half (the very first, parked from the simulator's
    start joints), the others from where the arm let go of its previous block, and an attempt after a failure
    from home, parked from where the failed attempt stopped the arm, its cables as they were there
    (`trees/shared/recover.yaml`'s `look_again`: let go, `park`, sense). A handover's exchange and its
    receiver's carry are `hand_over`'s, retried and fetched again as the trees do when `attempts` allow a
    recovery (pegbt's trees; the paper's robot tried each block once). A transfer whose goal peg held a
    block as it began is not placed, whatever it put there (`pegbt.executive.phases.transfer_outcomes`: the
    robot's look before it began saw the peg taken; a fetch picks the block on its goal peg first).
    `receiver_parked`: the trial's handover before this one failed, so its receiver was parked at home."""
    order = transfers(variant)
    arm, start_peg, goal_peg = order[index]
    previous_peg = next(goal for other, _, goal in reversed(order + order[:index]) if other == arm)
    strays = transfer_strays("reference")[index] if variant == "handover" else ()
    own = next((b.index for b in world.blocks if b.peg == start_peg), None)
    half = len(order) // 2
    mine = [i for i, (other, _, _) in enumerate(order) if other == arm]
    from_home = index in (0, half) or receiver_parked  # else from over its last goal peg
    trying = Trying(
        world,
        _skills(condition, variant),
        variant,
        arm,
        replay,
        rng,
        registered,
        attempts,
        came_from=None if index == mine[0] else previous_peg,
        parks=index in (mine[0], next((i for i in mine if i >= half), None)),  # parked before each half
        choose=(lambda again: pick(world, start_peg, again, strays)) if pick else (lambda again: own),
        looks_again=pick is not None,
        fetch=pick or (lambda *_: own),
        strays=strays,
        receiver_from=None if from_home else order[index - 1][2],
        receiver_parks=from_home,
        set_back_to=start_peg if variant == "handover" and attempts > 1 else None,
    )
    taken = any(b.peg == goal_peg and not b.lost for b in world.blocks)
    result = trying.run(goal_peg, 1 + REGRASPS)
    if result.succeeded and taken:  # as a tick log is read: a block put on a peg seen taken is no placing
        return replace(result, succeeded=False, phase=result.phase or "release")
    return result
