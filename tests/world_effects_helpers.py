"""Scripted motions for world-effect tests: a vertical tool grasps, lifts (with a sideways drift), carries
and places blocks, each step off by a given error, as an uncalibrated arm would be."""

import dataclasses
import hashlib

import numpy as np

from pegbt.motion.settings import motion_settings
from pegbt.sim.scripted import (
    Driver,
    Keyframe,
    grasp_candidate_facing,
    grasp_keyframes,
    lifted,
    parked,
    place_keyframes,
)

UNILATERAL = (
    (1, 7),
    (0, 6),
    (3, 8),
    (2, 9),
    (5, 11),
    (4, 10),
)  # the paper's first half (start peg, goal peg)


def outward(world, block=1, arm="PSM1"):
    """The outward normal (board x, y, 0) of the wall `arm` grasps block `block` by."""
    candidate = grasp_candidate_facing(world, block, arm)
    return np.append(world.blocks[block].pose[:2, :2] @ world.cell.block.edge_normals[candidate // 2], 0.0)


def shifted(frame, by):
    """`frame` moved by `by` (board x, y[, z], metres)."""
    return Keyframe(frame.position + np.resize(np.append(by, [0.0] * (3 - len(by))), 3), frame.yaw, frame.jaw)


def grasp_block(world, driver, block, arm="PSM1", error=(0.0, 0.0, 0.0)):
    frames = grasp_keyframes(world, block, grasp_candidate_facing(world, block, arm), np.asarray(error))
    return driver.play({arm: frames}), frames[-1]


def lift_block(world, driver, holding, arm="PSM1", drift=(0.0, 0.0)):
    """Straight up to the carry height, drifting sideways by `drift` on the way."""
    return driver.play({arm: [shifted(lifted(world, holding), drift)]})


def place_block(world, driver, block, goal_peg, arm="PSM1", error=(0.0, 0.0)):
    return driver.play(
        {arm: place_keyframes(world, block, goal_peg, driver.at(arm), error=np.asarray(error))}
    )


def noisy_transfer(world, driver, arm, block, goal_peg, grasp_error, lift_drift, place_error):
    """One transfer, each step off as given; a block lost on the way is let go and the arm parks."""
    events, holding = grasp_block(world, driver, block, arm, grasp_error)
    events += lift_block(world, driver, holding, arm, lift_drift)
    if world.held_by(arm) == block:
        events += place_block(world, driver, block, goal_peg, arm, place_error)
    else:
        opened = Keyframe(driver.at(arm).position, driver.at(arm).yaw, motion_settings().transfer.jaw_open)
        events += driver.play({arm: [opened]})
    return events + driver.play({arm: [parked(world, arm)]})


def noisy_unilateral(world, seed, give=0.0, sigma=0.0012):
    """The paper's first six unilateral transfers with seeded errors of `sigma` (m) in grasp, lift and
    placement, the wrist giving `give` (m) each way; returns every event."""
    rng = np.random.default_rng(seed)
    driver = YieldingDriver(world, (give,) * 4)
    events = []
    for start, goal in UNILATERAL:
        block = next(b.index for b in world.blocks if b.peg == start and b.state == "on_peg")
        errors = rng.normal(0.0, sigma, 7)
        events += noisy_transfer(
            world, driver, "PSM1", block, goal, [*errors[:2], 0.0], errors[2:4], errors[4:6]
        )
    return events


def digest(events):
    """A fingerprint of an event sequence: times, kinds, arms, blocks, pegs and details."""
    text = "\n".join(f"{e.time:.6f} {e.kind} {e.arm} {e.block} {e.peg} {e.detail}" for e in events)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class YieldingDriver(Driver):
    """Scripted tools whose wrists give `give` (m) along the tip's -x, +x, -y and +y, as cable play lets them."""

    def __init__(self, world, give):
        super().__init__(world)
        self.give = give

    def tool(self, arm, frame):
        return dataclasses.replace(super().tool(arm, frame), give=self.give)
