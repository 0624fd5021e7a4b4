"""What the phase simulator shares across the worlds of one transfer is never another world's answer: a
grasp (and a handover's meeting) kept in the transfer's `Replay` is the one chosen afresh for the block as
seen there, and each bench's cables, built from effects read once, are its own."""

import numpy as np

from pegbt.behaviours.meeting import plan_meeting
from pegbt.perception.blocks import BlockEstimate
from pegbt.sim.world import World
from pegbt.sim2real.outcomes import phasesim
from pegbt.sim2real.outcomes.attempt import chosen_grasp
from pegbt.sim2real.outcomes.bench import START, Bench, Replay


def _seen(world: World, block: int, shift: float = 0.0, yaw: float = 0.0) -> BlockEstimate:
    truth = world.blocks[block]
    position = truth.pose[:3, 3] + [shift, 0.0, 0.0]
    return BlockEstimate(position, yaw, truth.peg, 1.0, 0.0, 0, True, "")


def _key(choice: tuple) -> tuple:
    grasp, meeting = choice
    return (
        None if grasp is None else (grasp.candidate, grasp.pose.tobytes()),
        None if meeting is None else (meeting.tip.tobytes(), meeting.receiver_grasp.candidate),
    )


def test_a_kept_grasp_is_the_one_chosen_afresh_for_the_block_as_seen():
    world = World(4)
    handover, unilateral = phasesim._skills("uncalibrated", "handover"), phasesim._skills("uncalibrated")
    asks = [
        (handover, "PSM1", _seen(world, 0), (), plan_meeting),
        (handover, "PSM1", _seen(world, 0), (), None),  # the same block, not handed over
        (handover, "PSM1", _seen(world, 0, shift=0.002), (), plan_meeting),  # seen elsewhere
        (handover, "PSM1", _seen(world, 0, yaw=0.5), (), plan_meeting),  # seen turned
        (handover, "PSM1", _seen(world, 0, yaw=-0.0), (), plan_meeting),  # -0.0 is not 0.0's key
        (unilateral, "PSM1", _seen(world, 1), (), None),
        (unilateral, "PSM2", _seen(world, 1), (), None),  # another arm
        (phasesim._skills("calibrated"), "PSM1", _seen(world, 1), (), None),  # another condition
    ]
    first = chosen_grasp(unilateral, "PSM1", _seen(world, 1), (), None, Replay())
    asks.append((unilateral, "PSM1", _seen(world, 1), (first[0].candidate,), None))  # avoiding the last
    shared = Replay()
    kept = [_key(chosen_grasp(*ask, shared)) for ask in asks]
    afresh = [_key(chosen_grasp(*ask, Replay())) for ask in asks]
    assert kept == afresh
    again = [_key(chosen_grasp(*ask, shared)) for ask in asks]
    assert again == kept and len(shared.choices) == len(asks)
    assert kept[0][1] is not None and kept[1][1] is None
    assert kept[0][0] != kept[2][0] != kept[3][0] and kept[5][0] != kept[6][0]
    assert kept[-1][0] is not None and kept[-1][0][0] != first[0].candidate


def test_each_bench_has_cables_of_its_own():
    motion = phasesim._skills("uncalibrated").arm("PSM1")
    replay = Replay()
    one, other = (Bench(World(1), "PSM1", motion, START, replay) for _ in range(2))
    assert one.arm.physics is not other.arm.physics
    before = other.arm.physics.step(START, 0.01)
    for q in np.linspace(START, START + [0.2, -0.2, 0.01, 0.5, 0.5, -0.5], 50):
        one.arm.physics.step(q, 0.01)
    assert other.arm.physics.step(START, 0.01).tobytes() == before.tobytes()
    assert one.arm.physics.step(START, 0.01).tobytes() != before.tobytes()
