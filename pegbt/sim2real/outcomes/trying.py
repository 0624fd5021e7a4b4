"""One arm's attempts at a transfer's block, each after the last failed, as the trees recover
(`trees/shared/recover.yaml`'s `look_again`, `trees/shared/handover.yaml`'s `fetch`): what the attempts
share (the world, the arm's last attempt, the transfer's first failure and its start) and when they stop.

A handover's giver that holds its block at the meeting point hands it over (`exchange`); a receiver whose
block slipped fetches it with attempts of its own, from here again. A giver whose fallen block has no grasp
both clear of the pegs and one the receiver can take sets it back on its start peg first
(`trees/shared/set_back.yaml`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pegbt.behaviours.resources.skills import Skills
from pegbt.sim.world import World
from pegbt.sim2real.outcomes.attempt import failed_phase, pick_and_carry
from pegbt.sim2real.outcomes.bench import Bench, Chosen, Replay
from pegbt.sim2real.outcomes.exchange import hand_over
from pegbt.sim2real.outcomes.transfer_result import TransferResult

# the recoveries of a handover receiver's fetch of a block that slipped from it
# (`trees/shared/handover.yaml`'s `fetch`)
FETCH_REGRASPS = 2


# which block an attempt goes after: (world, pick peg, whether the transfer lost its block already, the
# pegs a lost block may have fallen onto alone) -> the block's index, or None when it finds none
Pick = Callable[[World, int, bool, tuple[int, ...]], int | None]


class Trying:
    """One arm's picks and carries of a transfer's block, each after the last failed (`phasesim.carry_out`): what
    they share across attempts."""

    def __init__(
        self,
        world: World,
        skills: Skills,
        variant: str,
        arm: str,
        replay: Replay,
        rng: np.random.Generator,
        registered: bool,
        attempts: int,
        *,
        choose: Callable[[bool], int | None],
        came_from: int | None = None,
        parks: bool = True,
        looks_again: bool = True,
        fetch: Pick = lambda *_: None,
        strays: tuple[int, ...] = (),
        receiver_from: int | None = None,
        receiver_parks: bool = False,
        failed: Bench | None = None,
        first: str | None = None,
        began: float | None = None,
        set_back_to: int | None = None,
    ) -> None:
        """`choose`: the block an attempt goes after (given whether it is a recovery); `came_from`: the peg
        the arm let go over last (None: home); `parks`: it parks before its first attempt; `looks_again`: a
        pick that finds no block recovers; `fetch`, `strays`: a handover receiver's fetch of a slipped block
        (`fetched`); `receiver_from`, `receiver_parks`: where a handover's receiver let go last, and whether
        it parks before it goes to the meeting; `failed`, `first`, `began`: the attempt, failure and time
        an earlier loop left (a fetch goes on from the receiver's carry); `set_back_to`: a handover giver's
        start peg, where it sets back a fallen block it has no grasp to hand over by (None: it gives up)."""
        self.world, self.skills, self.variant, self.arm = world, skills, variant, arm
        self.replay, self.rng, self.registered, self.attempts = replay, rng, registered, attempts
        self.choose, self.came_from, self.parks, self.looks_again = choose, came_from, parks, looks_again
        self.fetch, self.strays = fetch, strays
        self.receiver_from, self.receiver_parks = receiver_from, receiver_parks
        self.failed = failed  # the last attempt the arm set out on
        self.first = first
        self.began = world.time if began is None else began
        self.set_back_to = set_back_to

    def run(self, goal_peg: int, tries: int) -> TransferResult:
        """Up to `tries` picks (`self.attempts` of them set out) of the block `choose` names, each carried
        to `goal_peg`; the first held at a handover's meeting point is handed over."""
        world, skills, arm = self.world, self.skills, self.arm
        made = 0  # attempts the arm set out on (a grasp or meeting refused before moving is planned again)
        chose: Chosen | None = None
        for attempt in range(tries):
            if made == self.attempts:
                break
            block = self.choose(attempt > 0)
            if block is None or world.blocks[block].lost:
                if not self.looks_again:
                    break
                self.first, self.parks = self.first or "sense", True  # the recovery parks before it looks
                continue
            bench = pick_and_carry(
                world,
                skills,
                arm,
                block,
                goal_peg,
                self.rng,
                self.came_from,
                self.replay,
                self.variant,
                chose,
                self.registered,
                self.parks,
                self.failed,
            )
            if self._sets_back(bench, block):
                bench = self._set_back(block, chose)
                made += bench.moved
                chose = bench.chose or chose
                self.failed = bench if bench.moved else self.failed
                if bench.failed is None:
                    continue  # it looks again parked, from where the set-back left the arm (`look_again`)
            made += bench.moved
            chose = bench.chose or chose
            self.failed = bench if bench.moved else self.failed
            if bench.held and bench.meeting is not None:
                return hand_over(self, bench, block, goal_peg)
            if bench.held:
                bench.jaw(skills.motion.transfer.jaw_open, "release")
                placed = world.blocks[block]
                if placed.peg == goal_peg and not placed.grips:
                    return TransferResult(True, self.first, world.time - self.began, over_goal=True)
                phase = self.first or failed_phase(bench.events, block)
                return TransferResult(False, phase, world.time - self.began, over_goal=True)
            self.first = self.first or bench.failed
            if world.held_by(arm) is not None:
                bench.jaw(skills.motion.transfer.jaw_open, "grasp")
        return TransferResult(False, self.first or "grasp", world.time - self.began)

    def _sets_back(self, bench: Bench, block: int) -> bool:
        """Whether the giver found no grasp to hand its fallen block over by (`set_back_to` given, the block
        loose on the board): `select_grasp` failed before the arm moved."""
        lies = self.world.blocks[block]
        return (
            self.set_back_to is not None
            and bench.failed == "sense"
            and not bench.moved
            and lies.peg is None
            and not lies.lost
            and not lies.grips
        )

    def _set_back(self, block: int, chose: Chosen | None) -> Bench:
        """Pick the fallen block by a grasp clear of the pegs, whatever the receiver could take, carry it onto
        the start peg and let go (`set_back.yaml`'s `set_back`: `pick`, `lift`, `place`): one arm's pick
        and carry; the next attempt looks again and picks it there."""
        assert self.set_back_to is not None
        bench = pick_and_carry(
            self.world,
            self.skills,
            self.arm,
            block,
            self.set_back_to,
            self.rng,
            self.came_from,
            self.replay,
            "unilateral",
            chose,
            self.registered,
            self.parks,
            self.failed,
        )
        if bench.held:
            bench.jaw(self.skills.motion.transfer.jaw_open, "release")
            if self.world.blocks[block].peg != self.set_back_to:
                bench.failed = failed_phase(bench.events, block)
        self.first = self.first or bench.failed
        return bench

    def fetched(self, taker: Bench, goal_peg: int, first: str) -> tuple[TransferResult, Bench]:
        """The receiver lost its block on its way to `goal_peg` (its first failure `first`): it looks again,
        picks the block on that peg, else the loose one nearest it, and carries it there, recovering
        `FETCH_REGRASPS` times (`trees/shared/handover.yaml`'s `fetch`, its `pick` and `lift` as a one-arm
        transfer's); with the receiver's arm as the fetch left it."""
        fetching = Trying(
            self.world,
            self.skills,
            "unilateral",  # one arm's pick and carry: no meeting
            taker.name,
            self.replay,
            self.rng,
            self.registered,
            1 + FETCH_REGRASPS,
            choose=lambda again: self.fetch(self.world, goal_peg, True, self.strays),
            failed=taker,
            first=first,
            began=self.began,
        )
        return fetching.run(goal_peg, 1 + FETCH_REGRASPS), fetching.failed or taker
