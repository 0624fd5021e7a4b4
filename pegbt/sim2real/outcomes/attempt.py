"""One pick and carry of a block as it lies: seen with perception's noise, its grasp chosen as the
executive chooses it, approached, closed on, lifted and carried to its goal peg or to a handover's meeting
point, the arm's motions as the condition sends them.

Kept apart from the recoveries around it (`trying`) and from the exchange at a handover (`exchange`): an
attempt knows nothing of what went before except the arm it goes on with and the last look at the block.
"""

from __future__ import annotations

import struct
from functools import partial

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.actions.grasping import SAME_BLOCK
from pegbt.behaviours.meeting import Meet, Meeting, plan_meeting
from pegbt.behaviours.motion import above_pegs_first, planned_approach
from pegbt.behaviours.paper_meeting import paper_carry, paper_meeting
from pegbt.behaviours.poses import to_handover, tool_pose, transfer_for
from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.behaviours.resources.skills import Skills
from pegbt.errors import PegbtError
from pegbt.frames import yaw_of
from pegbt.motion.ik import inverse_kinematics, solve_ik
from pegbt.motion.placing import segment_times, stopped_above
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import Grasp
from pegbt.perception.servo import correction
from pegbt.sim.events import Event
from pegbt.sim.world import World
from pegbt.sim2real.outcomes.bench import START, Bench, Chosen, Replay
from pegbt.sim2real.outcomes.cells import PHASES
from pegbt.sim2real.outcomes.paperplacing import paper_transfer
from pegbt.sim2real.outcomes.placelook import visible_points
from pegbt.sim2real.outcomes.transfer_order import RECEIVER

# m per axis: the error of a block's position as pegbt's perception fits it in a whole trial (its fit
# averages the camera's 0.3 mm depth noise over some 1,200 points): 0.04-0.08 mm rms in the concealed
# campaign's first looks, 0.03-0.05 mm at the looks before lowering (docs/guides/sim-to-real.md); a world's
# `perception_noise` adds to it (`look_sd`)
PERCEPTION_SD = 0.00005
# the conditions under which the carry opens the jaw as it comes down (`trees/shared/lift.yaml`'s
# `let_go_early`); under the others it lets go at rest
LETS_GO_EARLY = ("calibrated", "optimized")


def seen_point(world: World, point: NDArray[np.float64]) -> NDArray[np.float64]:
    """Where perception finds a block's point (board frame): `depth_bias` farther along the camera's ray
    (`pegbt.sim.camera` lengthens the rays meeting blocks; the board and its pegs are measured true)."""
    bias = world.effects.values("depth_bias")["bias"]
    ray = point - world.cell.camera.board_from_camera[:3, 3]
    return point + bias * ray / np.linalg.norm(ray)


def look_sd(world: World) -> float:
    """The error (m per board axis) of a look at a block: pegbt's perception's own and the world's
    `perception_noise`, independent."""
    return float(np.hypot(PERCEPTION_SD, world.effects.values("perception_noise")["sd"]))


def previous_release(
    world: World, arm: str, dropped: NDArray[np.float64], goal_peg: int, previous_peg: int
) -> NDArray[np.float64]:
    """Where `arm` let go of a block lowered over `previous_peg` (its tip pose in its frame, as `dropped`
    over `goal_peg` but over `previous_peg`): an attempt starts there, its cables at rest."""
    to_arm = world.cell.board_to_arm(arm)
    shift = to_arm[:3, :3] @ (world.cell.pegs.tops[previous_peg] - world.cell.pegs.tops[goal_peg])
    start = dropped.copy()
    start[:3, 3] += shift
    return start


def pick_and_carry(
    world: World,
    skills: Skills,
    arm: str,
    block: int,
    goal_peg: int,
    rng: np.random.Generator,
    came_from: int | None,
    replay: Replay,
    variant: str = "unilateral",
    chose: Chosen | None = None,
    registered: bool = False,
    parks: bool = False,
    after: Bench | None = None,
) -> Bench:
    """One pick and carry of `block` as it lies, seen with perception's noise (as at the last look, `chose`,
    if it has not moved since): the bench afterwards says
    whether the arm holds it lowered over `goal_peg`, or at the meeting point for a `handover` (`held`,
    with `meeting`), or in which phase it was lost (`failed`). A pick again of the block seen where the
    last attempt `chose` its grasp avoids that candidate, as `SelectGrasp` does
    (`pegbt/behaviours/actions/grasping.py`, `trees/shared/grasp.yaml`'s `another`). The arm starts lowered
    over peg `came_from` (None: at the simulator's start joints) and, when it `parks`, first goes home as
    `Park` does (`pegbt/behaviours/actions/moving.py`); it approaches as `Approach` does. An attempt `after`
    one that failed goes on with that attempt's arm from where it stopped, and parks. A `registered` arm
    (the paper's protocol) on rest-to-rest cubics carries at the paper's heights and looks before it
    lowers (`looks_before_lowering`, `paper_place`) at the paper's placing angle (`paperplacing`); as a
    handover's giver it carries to the paper's meeting (`paperhandover`)."""
    handover = variant == "handover"
    truth = world.blocks[block]
    if chose is not None and np.array_equal(chose.truth, truth.pose):
        noise = chose.error  # the block lies as it did at the last look: perception sees it as then
    else:
        noise = rng.normal(0.0, look_sd(world), 2)
    position = seen_point(world, truth.pose[:3, 3]) + [noise[0], noise[1], 0.0]
    seen = BlockEstimate(position, yaw_of(truth.pose), truth.peg, 1.0, 0.0, 0, True, "")
    motion = skills.arm(arm)
    looks = looks_before_lowering(registered, motion)
    same = chose is not None and np.linalg.norm(chose.position[:2] - position[:2]) <= SAME_BLOCK
    avoid = (chose.candidate,) if same and chose else ()
    meet = paper_meeting if looks else plan_meeting
    grasp, meeting = chosen_grasp(skills, arm, seen, avoid, meet if handover else None, replay)
    if grasp is None:
        return Bench.failed_before(world, arm, motion, "sense")
    if meeting is None and looks:
        waypoints = paper_transfer(world.cell, skills.motion, arm, seen, grasp, goal_peg, variant)
    elif meeting is None:
        waypoints = transfer_for(world.cell, skills.motion, arm, None, seen, grasp, goal_peg)
    elif looks:
        waypoints = paper_carry(world.cell, skills.motion, arm, None, seen, grasp, meeting.tip)
    else:
        waypoints = to_handover(world.cell, skills.motion, arm, None, seen, grasp, meeting.tip)
    if waypoints.approach is None:
        return Bench.failed_before(world, arm, motion, "reach")
    if after is not None:
        bench = after.again(skills.motion.transfer.jaw_open)
        q0, parks = bench.arm.joints.setpoint.copy(), True
    elif came_from is None:
        q0 = START
    else:
        start = previous_release(world, arm, waypoints.poses[3], goal_peg, came_from)
        ik = inverse_kinematics(start[None], motion.settings)
        if not ik.ok.all():
            return Bench.failed_before(world, arm, motion, "reach")
        q0 = ik.q[0]
    if after is None:
        bench = Bench(world, arm, motion, q0, replay, registered)
    bench.chose = Chosen(position, grasp.candidate, truth.pose.copy(), noise)
    try:
        if parks:
            park = planned_park(world, skills, arm, q0)
            bench.play(park, [(0.0, "reach")])
            q0 = park.q[-1]
        reach = planned_approach(skills, arm, q0, None, seen, grasp)
    except PegbtError:  # the approach leaf fails to plan: nothing moves
        bench.failed, bench.moved = "reach", False
        return bench
    bench.play(reach, [(0.0, "reach")])
    bench.jaw(skills.motion.transfer.jaw_closed, "grasp")
    if world.held_by(arm) != block:
        bench.failed = "grasp"
        return bench
    try:
        planned = motion.transfer(waypoints)
    except PegbtError:  # the carrying leaf fails to plan (a goal out of reach): the tick log says carry
        bench.failed = "carry"
        return bench
    lifted, lowering = segment_times(planned)
    let_go = None
    if skills.condition in LETS_GO_EARLY and not registered and meeting is None:
        let_go = _letting_go(skills, motion)  # the paper's robot, and a giver, let go at rest
    if looks and meeting is None:
        paper_place(bench, planned, waypoints, block, goal_peg, rng, [(0.0, "lift"), (lifted, "carry")])
    else:
        segments = [(0.0, "lift"), (lifted, "carry"), (lowering, "lower")]
        bench.play(planned, segments, holding=block, let_go=let_go)
    bench.held = (world.held_by(arm) == block or bench.let_go) and bench.failed is None
    bench.meeting = meeting
    if not bench.held:
        bench.failed = failed_phase(bench.events, block)
    return bench


def chosen_grasp(
    skills: Skills,
    arm: str,
    seen: BlockEstimate,
    avoid: tuple[int, ...],
    meet: Meet | None,
    replay: Replay,
) -> tuple[Grasp | None, Meeting | None]:
    """`arm`'s grasp of the block `seen` as `select_grasp` picks it (`avoid`: the candidate that just
    missed), and, for a handover's giver (`meet`), the meeting it plans from it: a giver chooses among the
    grasps its receiver can take the block from (`select_grasp`'s `handover_to`). Both depend on what is
    seen alone, so the worlds of one transfer that see the block alike share them (`Replay.choices`)."""
    key = (skills.selectors[arm], seen.position.tobytes(), struct.pack("d", seen.yaw), seen.peg, avoid, meet)
    known = replay.choices.get(key)
    if known is not None:
        return known
    acceptable = None if meet is None else partial(_handed, meet, skills, arm, seen)
    grasp = skills.selectors[arm].pick(seen, avoid=avoid, acceptable=acceptable)
    meeting = None
    if grasp is not None and meet is not None:
        meeting = meet(skills, arm, RECEIVER[arm], grasp, seen)
        assert meeting is not None  # the grasp was chosen among those `_handed` accepts
    known = replay.choices[key] = (grasp, meeting)
    return known


def _handed(meet: Meet, skills: Skills, arm: str, seen: BlockEstimate, option: Grasp) -> bool:
    """Whether `arm`'s receiver can take the block `seen` from it holding it by `option` at the meeting
    `meet` plans (`handed`); a meeting the giver cannot reach is none."""
    try:
        return meet(skills, arm, RECEIVER[arm], option, seen) is not None
    except PegbtError:
        return False


def looks_before_lowering(registered: bool, motion: ArmMotion) -> bool:
    """Whether a transfer is placed as the paper's robot placed it (`paper_place`): under its protocol,
    with the rest-to-rest cubics of its `transfer_block_traj` (`use_optimization = False`), which stop
    over the goal peg. Its optimised trajectory went on down to `height_drop` and looked there, then rose
    again; that is not played here: an optimised paper-protocol transfer lowers without looking."""
    return registered and motion.planner is None


def paper_place(
    bench: Bench,
    planned: Trajectory,
    waypoints: TransferWaypoints,
    block: int,
    goal_peg: int,
    rng: np.random.Generator,
    segments: list[tuple[float, str]],
) -> None:
    """The paper's placing (`placelook`): `planned` played up to its stop above `goal_peg` (`segments`
    name its phases), the held block seen there as perception sees a block (`seen_point`, `look_sd`
    in board x, y), the arm moved by `servoing_block`'s correction over the peg (a rest-to-rest move of
    the arm as it is, so imperfect too) and down to the drop height, where `_transfer` opens the jaw."""
    bench.play(stopped_above(planned), segments, holding=block)
    world = bench.world
    if world.held_by(bench.name) != block:
        return
    noise = rng.normal(0.0, look_sd(world), 2)
    bottom = seen_point(world, world.blocks[block].pose[:3, 3]) + [noise[0], noise[1], 0.0]
    points = visible_points(world, goal_peg)
    move = correction(
        world.cell.board_to_arm(bench.name), world.cell.pegs.positions[goal_peg], bottom, points
    )
    above, dropped = waypoints.poses[2].copy(), waypoints.poses[3].copy()
    above[:3, 3] += move
    dropped[:3, 3] += move
    settings = bench.motion.settings
    try:
        joints = [solve_ik(pose, settings, what=f"{bench.name} place") for pose in (above, dropped)]
        servo = bench.motion.through(bench.arm.joints.setpoint.copy(), joints, ["servo", "drop"])
    except PegbtError:  # the corrected place is out of reach: the robot's command fails there
        bench.failed = "lower"
        return
    moved, _ = segment_times(servo)
    bench.play(servo, [(0.0, "carry"), (moved, "lower")], holding=block)


def planned_park(world: World, skills: Skills, arm: str, start: NDArray[np.float64]) -> Trajectory:
    """`arm` from joints `start` to its home pose out of the camera's view, straight up first if low
    among the pegs (`Park`, `pegbt/behaviours/actions/moving.py`)."""
    motion, cell = skills.arm(arm), world.cell
    home = tool_pose(motion.settings.home_tip, 0.0, cell.up_in(arm))
    joints = above_pegs_first(cell, skills.motion, arm, start, motion.settings)
    joints.append(solve_ik(home, motion.settings, what=f"{arm} home pose"))
    names = [f"stop {i}" for i in range(len(joints) - 1)] + ["home"]
    return motion.through(start, joints, names)


def _letting_go(skills: Skills, motion: ArmMotion) -> tuple[float, float]:
    """When (s before a carry's planned end) and how far the trees' carry opens the jaw as it comes down:
    reaching `jaw_release` as the arm stops (`Transfer.begin`)."""
    transfer = skills.motion.transfer
    return (transfer.jaw_release - transfer.jaw_closed) / motion.settings.jaw_velocity, transfer.jaw_release


def failed_phase(events: list[tuple[str, Event]], block: int) -> str:
    """The segment in which the block was first lost: knocked loose, slipped, dropped or misplaced."""
    for segment, event in events:
        if (
            event.block == block
            and event.kind in ("collision", "slip", "drop")
            and (event.kind != "collision" or "block-peg" in event.detail)
        ):
            return segment if segment in PHASES else "carry"
    return "release"
