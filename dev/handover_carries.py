"""The handover givers' carries to the meeting point, each planned alone, against `pegbt bench limit`'s bound.

For each of the handover's 12 transfers (`trees/shared/orders.yaml`, PSM2 giving the first six): the block
a world of `--seed` puts on its peg (the first half's blocks moved to the other side for the second), the
grasp and meeting the trial would choose, the optimised plan of the carry (`to_handover`'s waypoints), and
three bounds (`pegbt.bench.limit_bound.through`): the bound's own carry (its grasp on the peg's axis, lifted
until the block's bottom is at the peg's top), the same from pegbt's grasp to pegbt's meeting joints, and
that lifted on the grasp's line to the channel's clearing height (`channel_margin` higher). Run:
`PYTHONPATH=$PWD .venv/bin/python dev/handover_carries.py --seed 2` (docs/internals/motion.md).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from pegbt.behaviours.actions.handover import handed
from pegbt.behaviours.meeting import plan_meeting
from pegbt.behaviours.poses import to_handover
from pegbt.behaviours.resources.skills import Skills
from pegbt.bench.limit_bound import Bound, through
from pegbt.motion.ik import solve_ik
from pegbt.motion.transfer import joint_waypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World
from pegbt.sim2real.outcomes.phasesim import transfers


def block_on(blocks: list[BlockEstimate], peg: int, skills: Skills) -> BlockEstimate:
    """The block seen on `peg`, or the one on the peg six before moved onto it (the second half's)."""
    seen = {block.peg: block for block in blocks}
    if peg in seen:
        return seen[peg]
    tops = skills.cell.pegs.tops
    source = seen[peg - 6]
    return replace(source, position=source.position + (tops[peg] - tops[peg - 6]) * [1.0, 1.0, 0.0], peg=peg)


@dataclass(frozen=True)
class Carry:
    """One giver's carry: its plan's duration and method, and the three bounds (s)."""

    giver: str
    peg: int
    planned: float
    method: str
    bound: float  # the bound's own carry
    from_ends: float  # from pegbt's grasp to pegbt's meeting joints
    with_margin: float  # the same, lifted to the channel's clearing height


def carries(seed: int) -> list[Carry]:
    """The handover's carries with the blocks of a world of `seed` (those the receiver can take)."""
    skills, bound = Skills("optimized"), Bound()
    cloud = DepthCamera(seed=0).capture(World(seed=seed))
    board = skills.registration.fit(cloud)
    blocks = skills.locator.locate(cloud, board)
    margin = skills.motion.transfer.channel_margin
    found = []
    for giver, pick, _ in transfers("handover"):
        receiver = "PSM1" if giver == "PSM2" else "PSM2"
        block = block_on(blocks, pick, skills)
        grasp = skills.selectors[giver].pick(
            block, acceptable=partial(handed, skills, giver, receiver, block)
        )
        meeting = plan_meeting(skills, giver, receiver, grasp, block) if grasp is not None else None
        planner = skills.arm(giver).planner
        if grasp is None or meeting is None or planner is None:
            continue
        waypoints = to_handover(skills.cell, skills.motion, giver, board, block, grasp, meeting.tip)
        plan = planner.plan(waypoints)
        settings, q = bound.settings[giver], joint_waypoints(waypoints, bound.settings[giver])
        channel = waypoints.pick
        assert channel is not None  # a carry off a peg
        lifts = []
        for extra in (-margin, 0.0):
            lifted = waypoints.poses[0].copy()
            lifted[:3, 3] += (channel.clear + extra) * channel.axis
            lifts.append(through(q[0], [solve_ik(lifted, settings)], q[-1], settings))
        own = bound.lift_to(
            giver, bound.joints(giver, pick, bound.grasp_height()), pick, bound.meeting(giver)
        )
        found.append(Carry(giver, pick, plan.trajectory.duration, plan.method, own, *lifts))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2, help="the world whose blocks are carried")
    found = carries(parser.parse_args().seed)
    print("giver peg  planned method | bound  from pegbt's ends  with the channel's margin")
    for c in found:
        print(
            f"{c.giver} {c.peg:4d}  {c.planned:7.3f} {c.method:6s} | {c.bound:.3f}  {c.from_ends:.3f}  {c.with_margin:.3f}"
        )
    means = np.mean([[c.planned, c.bound, c.from_ends, c.with_margin] for c in found], axis=0)
    print("mean       {:7.3f}        | {:.3f}  {:.3f}  {:.3f}".format(*means))


if __name__ == "__main__":
    main()
