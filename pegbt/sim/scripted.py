"""Scripted tool motions for the world: keyframes of a vertical tool, interpolated at the control period.

Tests and benchmarks drive `World.update` with these instead of a full arm, so the world's rules can be
exercised (and timed) alone. The standard transfer follows the reference's waypoints: above the grasp,
down onto it, close, straight up off the peg, across, down onto the goal peg, open, up.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from pegbt.frames import Matrix, yaw_of
from pegbt.motion.settings import motion_settings
from pegbt.psm import ARMS
from pegbt.sim.events import Event
from pegbt.sim.tools import ToolState, tool_pointing_down
from pegbt.sim.world import World

LIFT_MARGIN = 0.004  # the block's bottom clears the peg tops by this much when carried
PLACE_DEPTH = 0.003  # a block is released with its bottom this far down the goal peg


@dataclass(frozen=True)
class Keyframe:
    """A vertical tool's tip position (board frame), jaw-closing yaw and jaw angle."""

    position: Matrix
    yaw: float
    jaw: float


def interpolate(
    keyframes: list[Keyframe], step: float, speed: float = 0.05, jaw_speed: float = 6.0
) -> Iterator[Keyframe]:
    """Keyframes every `step` seconds, moving in straight lines at `speed` (m/s), the jaw at `jaw_speed`."""
    for start, end in zip(keyframes, keyframes[1:]):
        distance = float(np.linalg.norm(end.position - start.position))
        duration = max(
            distance / speed, abs(end.jaw - start.jaw) / jaw_speed, abs(end.yaw - start.yaw) / math.pi, step
        )
        count = math.ceil(duration / step - 1e-9)
        for i in range(1, count + 1):
            f = i / count
            yield Keyframe(
                start.position + f * (end.position - start.position),
                start.yaw + f * (end.yaw - start.yaw),
                start.jaw + f * (end.jaw - start.jaw),
            )


def carry_height(world: World) -> float:
    """Tip z at which a gripped block's bottom clears the peg tops by `LIFT_MARGIN`."""
    model = world.cell.block
    return world.cell.pegs.top_z - LIFT_MARGIN - (model.height - model.grasp_depth)


def grasp_keyframes(world: World, block: int, candidate: int, error: Matrix = np.zeros(3)) -> list[Keyframe]:
    """Over the grasp, down onto it from just above the block (missing it by `error`), close the jaw."""
    model, motion = world.cell.block, motion_settings().transfer
    block_pose = world.blocks[block].pose
    grasp = (block_pose @ np.append(model.grasp_candidates.positions[candidate], 1.0))[:3] + error
    yaw = yaw_of(block_pose) + model.grasp_candidates.jaw_yaw[candidate]
    approach = grasp - [0.0, 0.0, model.grasp_depth + motion.approach_above_block]
    return [
        Keyframe(np.array([grasp[0], grasp[1], carry_height(world)]), yaw, motion.jaw_open),
        Keyframe(approach, yaw, motion.jaw_open),
        Keyframe(grasp, yaw, motion.jaw_open),
        Keyframe(grasp, yaw, motion.jaw_closed),
    ]


def lifted(world: World, frame: Keyframe) -> Keyframe:
    """`frame` raised straight up to the carry height."""
    return Keyframe(
        np.array([frame.position[0], frame.position[1], carry_height(world)]), frame.yaw, frame.jaw
    )


def place_keyframes(
    world: World, block: int, goal_peg: int, holding: Keyframe, error: Matrix = np.zeros(2)
) -> list[Keyframe]:
    """Carry the block gripped at `holding` over `goal_peg` (missing it by `error`), lower it, open, rise."""
    cell = world.cell
    offset = holding.position[:2] - world.blocks[block].pose[:2, 3]
    goal = cell.pegs.positions[goal_peg] + offset + error
    place_z = carry_height(world) + LIFT_MARGIN + PLACE_DEPTH
    above = Keyframe(np.array([goal[0], goal[1], carry_height(world)]), holding.yaw, holding.jaw)
    lowered = Keyframe(np.array([goal[0], goal[1], place_z]), holding.yaw, holding.jaw)
    jaw_open = motion_settings().transfer.jaw_open
    return [
        above,
        lowered,
        Keyframe(lowered.position, holding.yaw, jaw_open),
        Keyframe(above.position, holding.yaw, jaw_open),
    ]


def transfer_keyframes(world: World, block: int, goal_peg: int, candidate: int) -> list[Keyframe]:
    """The whole transfer of `block` onto `goal_peg` with grasp `candidate`, keeping the block's yaw."""
    grasp = grasp_keyframes(world, block, candidate)
    return [*grasp, lifted(world, grasp[-1]), *place_keyframes(world, block, goal_peg, grasp[-1])]


def parked(world: World, arm: str) -> Keyframe:
    """A closed tool 95 mm straight below the arm's remote centre (the reference home's depth), clear of the board."""
    return Keyframe(world.cell.remote_centre(arm) + [0.0, 0.0, 0.095], 0.0, 0.0)


def grasp_candidate_facing(world: World, block: int, arm: str) -> int:
    """The grasp candidate of `block` nearest (in x, y) to `arm`'s remote centre: the jaw works in front of the peg."""
    model = world.cell.block
    local = np.column_stack([model.grasp_candidates.positions, np.ones(6)])
    points = (world.blocks[block].pose @ local.T).T[:, :2]
    return int(np.argmin(np.linalg.norm(points - world.cell.remote_centre(arm)[:2], axis=1)))


class Driver:
    """Plays keyframe paths of vertical tools into a world at a fixed step, arms not moving stay put."""

    def __init__(self, world: World, step: float = 0.01, speed: float = 0.05) -> None:
        self.world = world
        self.step = step
        self.speed = speed
        self.poses = {arm: parked(world, arm) for arm in ARMS}

    def tool(self, arm: str, frame: Keyframe) -> ToolState:
        """The tool at `frame`, where it truly is: off by the world's registration offset, if any."""
        cell, world = self.world.cell, self.world
        position = (
            frame.position + world.registration_offset
            if world.effects.has("registration_offset")
            else frame.position
        )
        return tool_pointing_down(position, frame.yaw, frame.jaw, cell.remote_centre(arm), cell.tool)

    def play(self, paths: dict[str, list[Keyframe]]) -> list[Event]:
        """Move the named arms along their paths together (each starting from where it is); returns the events."""
        streams = {
            arm: list(interpolate([self.poses[arm], *frames], self.step, self.speed))
            for arm, frames in paths.items()
        }
        events: list[Event] = []
        for i in range(max(len(stream) for stream in streams.values())):
            for arm, stream in streams.items():
                self.poses[arm] = stream[min(i, len(stream) - 1)]
            time = self.world.time + self.step
            events += self.world.update(
                time, {arm: self.tool(arm, frame) for arm, frame in self.poses.items()}
            )
        return events

    def at(self, arm: str) -> Keyframe:
        """Where `arm`'s tool is now."""
        return self.poses[arm]
