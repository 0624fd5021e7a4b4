"""Scripted transfers for whole arms over the transport: the world's tool keyframes (`pegbt.sim.scripted`)
turned into joint motions by the closed-form IK, for tests and benchmarks that drive the simulator as an
executive would (a joint goal to the start, then joint trajectories for straight tool moves and jaw
moves), without any behaviour tree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.ik import IKSolution, inverse_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.sim.scripted import (
    Driver,
    Keyframe,
    grasp_candidate_facing,
    interpolate,
    parked,
    transfer_keyframes,
)
from pegbt.sim.tools import tool_pointing_down
from pegbt.sim.world import World
from pegbt.transport.arm import ArmClient, MotionHandle, MotionStatus
from pegbt.transport.codec import TrajectoryPoints
from pegbt.workcell import Workcell


@dataclass(frozen=True)
class ScriptedMotion:
    """One command: a joint goal, a joint trajectory, or a jaw angle (exactly one is set)."""

    goal: NDArray[np.float64] | None = None
    trajectory: TrajectoryPoints | None = None
    jaw: float | None = None


def _solve(cell: Workcell, arm: str, frames: list[Keyframe], turn: float) -> IKSolution:
    """IK of a vertical tool at each keyframe, its jaw-closing axis turned by `turn` from the keyframe's yaw."""
    to_arm, centre = cell.board_to_arm(arm), cell.remote_centre(arm)
    poses = [
        to_arm @ tool_pointing_down(f.position, f.yaw + turn, f.jaw, centre, cell.tool).tip for f in frames
    ]
    return inverse_kinematics(np.array(poses), arm_settings(arm))


def jaw_turn(cell: Workcell, arm: str, frames: list[Keyframe]) -> float:
    """0 or π: the jaw is symmetric, so a yaw and its opposite grip alike; the one that reaches every
    frame with the roll nearer zero at the first (one choice for a whole path: its roll never flips)."""
    usable = [
        (abs(s.q[0, 3]), turn) for turn in (0.0, math.pi) if (s := _solve(cell, arm, frames, turn)).ok.all()
    ]
    if not usable:
        keyframe_joints(cell, arm, frames, 0.0)  # raises, naming the first frame out of reach
    return min(usable)[1]


def keyframe_joints(cell: Workcell, arm: str, frames: list[Keyframe], turn: float) -> NDArray[np.float64]:
    """Joints (n, 6) putting `arm`'s tool at each keyframe: vertical, jaws closing along its yaw + `turn`."""
    solution = _solve(cell, arm, frames, turn)
    if not solution.ok.all():
        problems = solution.problems(int(np.argmin(solution.ok)))
        raise PegbtError(f"{arm} cannot reach the scripted path: {'; '.join(problems)}", field=arm)
    return solution.q


def joint_motions(
    cell: Workcell, arm: str, keyframes: list[Keyframe], step: float, speed: float
) -> list[ScriptedMotion]:
    """A joint goal to the first keyframe and its jaw angle, then each straight move as a joint trajectory
    sampled every `step` seconds at `speed` (m/s), and each jaw change as a jaw move."""
    turn = jaw_turn(cell, arm, keyframes)
    joints = keyframe_joints(cell, arm, keyframes, turn)
    motions = [ScriptedMotion(goal=joints[0]), ScriptedMotion(jaw=keyframes[0].jaw)]
    for start, end in zip(keyframes, keyframes[1:]):
        if not np.allclose(start.position, end.position) or start.yaw != end.yaw:
            q = keyframe_joints(cell, arm, list(interpolate([start, end], step, speed)), turn)
            motions.append(
                ScriptedMotion(
                    trajectory=TrajectoryPoints(step * np.arange(1, len(q) + 1, dtype=np.float64), q)
                )
            )
        if end.jaw != start.jaw:
            motions.append(ScriptedMotion(jaw=end.jaw))
    return motions


def descending_motions(
    world: World, arm: str, keyframes: list[Keyframe], step: float, speed: float
) -> list[ScriptedMotion]:
    """`keyframes` as joint motions, reached straight down from `arm`'s parking height (clear of the pegs)."""
    first = keyframes[0]
    above = Keyframe(np.append(first.position[:2], parked(world, arm).position[2]), first.yaw, first.jaw)
    return joint_motions(world.cell, arm, [above, *keyframes], step, speed)


def transfer_motions(
    world: World, arm: str, block: int, goal_peg: int, step: float, speed: float
) -> list[ScriptedMotion]:
    """`arm` moves `block` onto `goal_peg` as `world` stands now: down from its parking height above the
    block, the scripted transfer (`transfer_keyframes`), straight up again and back to its park."""
    keyframes = transfer_keyframes(world, block, goal_peg, grasp_candidate_facing(world, block, arm))
    park, last = parked(world, arm), keyframes[-1]
    rise = Keyframe(np.append(last.position[:2], park.position[2]), last.yaw, last.jaw)
    motions = descending_motions(world, arm, [*keyframes, rise], step, speed)
    return motions + [
        ScriptedMotion(goal=keyframe_joints(world.cell, arm, [park], jaw_turn(world.cell, arm, [park]))[0])
    ]


def scripted_trial(
    world: World, transfers: list[tuple[str, int, int]], step: float, speed: float
) -> list[tuple[str, list[ScriptedMotion]]]:
    """Each (arm, start peg, goal peg) transfer as that arm's motions, in order; `world` (a copy of the
    simulator's, same seed) plays them out on the way, so each transfer finds its block where the last left it."""
    driver = Driver(world, step=step, speed=speed)
    trial = []
    for arm, start_peg, goal_peg in transfers:
        block = next(b.index for b in world.blocks if b.peg == start_peg and b.state == "on_peg")
        trial.append((arm, transfer_motions(world, arm, block, goal_peg, step, speed)))
        driver.play(
            {arm: transfer_keyframes(world, block, goal_peg, grasp_candidate_facing(world, block, arm))}
        )
        driver.play({arm: [parked(world, arm)]})
    return trial


class MotionPlayer:
    """Plays one arm's motions in order through its `ArmClient`; `poll()` once per tick."""

    def __init__(self, client: ArmClient, motions: list[ScriptedMotion] | None = None) -> None:
        self.client = client
        self.pending: list[ScriptedMotion] = list(motions or [])
        self._handle: MotionHandle | None = None

    def extend(self, motions: list[ScriptedMotion]) -> None:
        self.pending.extend(motions)

    def poll(self) -> bool:
        """Start the next motion once the last is done; False when all are done. A failed motion raises."""
        if self._handle is not None:
            status = self._handle.status
            if status is MotionStatus.BUSY:
                return True
            if status is MotionStatus.FAILED:
                raise PegbtError(f"{self.client.name}: {self._handle.error}", field=self.client.name)
        if not self.pending:
            return False
        motion = self.pending.pop(0)
        if motion.jaw is not None:
            self._handle = self.client.jaw.move_jp(motion.jaw)
        else:
            target = motion.goal if motion.trajectory is None else motion.trajectory
            assert target is not None  # exactly one of goal, trajectory and jaw is set
            self._handle = self.client.move_jp(target)
        return True
