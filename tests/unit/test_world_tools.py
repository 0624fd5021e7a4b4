"""Tool states from the arm's forward kinematics grip blocks the way the jaw really closes."""

import numpy as np
import pytest

from pegbt.frames import invert_rigid, yaw_of, yaw_pose
from pegbt.motion.settings import motion_settings
from pegbt.sim.tools import ToolState
from pegbt.sim.world import World


def _tool(world, q, jaw):
    return ToolState.from_joints(np.asarray(q, dtype=float), jaw, world.cell.arm_to_board("PSM1"))


def test_the_home_pose_points_the_tool_down_into_the_board_under_the_remote_centre():
    world = World(seed=0)
    tool = _tool(world, [0, 0, 0.15, 0, 0, 0], 0.5)
    assert tool.tip[:3, 2] == pytest.approx(
        [0, 0, -1], abs=0.03
    )  # tool-tip z points back up, out of the board
    assert np.allclose(tool.shaft[0], world.cell.remote_centre("PSM1"))
    assert np.linalg.norm(tool.shaft[1] - tool.shaft[0]) == pytest.approx(0.15 - 0.4318 + 0.4162)
    wrist_to_tip = np.linalg.norm(tool.tip[:3, 3] - tool.shaft[1])
    assert wrist_to_tip == pytest.approx(world.cell.tool.wrist_length + world.cell.tool.jaw_length)


@pytest.mark.parametrize(("roll", "grips"), [(0.0, True), (np.pi, True), (np.pi / 2, False)])
def test_the_jaw_grips_across_the_wall_along_the_tip_x_axis(roll, grips):
    world = World(seed=0)
    q = [0.05, -0.03, 0.125, roll, 0.0, 0.0]
    tool = _tool(world, q, motion_settings().transfer.jaw_open)
    # lift block 1 off its peg and hold it upright, its first grasp candidate at the tool tip, wall across tip x
    candidates = world.cell.block.grasp_candidates
    yaw = yaw_of(_tool(world, q[:3] + [0, 0, 0], 0).tip) - candidates.jaw_yaw[0]
    upright = yaw_pose(np.zeros(3), yaw)
    offset = upright[:3, :3] @ candidates.positions[0]
    world.blocks[1].pose, world.blocks[1].peg = yaw_pose(tool.tip[:3, 3] - offset, yaw), None
    assert world.blocks[1].pose[2, 3] < world.cell.pegs.top_z  # clear of the pegs and the board
    assert (
        np.linalg.norm((invert_rigid(world.blocks[1].pose) @ tool.tip)[:3, 3] - candidates.positions[0])
        < 1e-9
    )
    world.update(0.01, {"PSM1": tool})
    events = world.update(0.02, {"PSM1": _tool(world, q, motion_settings().transfer.jaw_closed)})
    assert [event.kind for event in events] == (["grasp"] if grips else ["grasp_miss"])
    if grips:
        assert world.jaw_stop("PSM1") == pytest.approx(2 * np.arcsin(0.001 / 0.0095))
    else:
        assert world.jaw_stop("PSM1") is None


def test_a_joint_that_lags_in_its_play_can_be_pushed_across_it_towards_its_command():
    from pegbt.physics import ArmPhysics, Effect

    physics = ArmPhysics(
        [
            Effect("backlash", "q6", {"half_width": 0.05}),
            Effect("hysteresis", "q5", {"source": "q5", "half_width": 0.2, "k": 0.25}),
            Effect(
                "hysteresis", "q5", {"source": "q6", "half_width": 0.3, "k": -0.5}
            ),  # another drive's: no room
        ]
    )
    assert ArmPhysics().play_room("q6") == (0.0, 0.0)  # ideal cables: a rigid joint
    physics.reset(np.zeros(6))
    assert physics.play_room("q6") == pytest.approx((0.05, 0.05))  # settled mid-play
    assert physics.play_room("q5") == pytest.approx((0.05, 0.05))  # k · half-width either way
    physics.step([0, 0, 0, 0, 0.5, 0.5], 0.01)  # commanded up: both joints trail at the bottom of their play
    assert physics.play_room("q6") == pytest.approx((0.0, 0.1))
    assert physics.play_room("q5") == pytest.approx((0.0, 0.1))
    assert ArmPhysics(
        [Effect("hysteresis", "q5", {"source": "q5", "half_width": 0.2, "k": -0.25})]
    ).play_room("q5") == (0.0, 0.0)


def test_the_wrist_gives_along_the_tip_axes_as_its_play_lets_it():
    from pegbt.physics import ArmPhysics, Effect
    from pegbt.sim.tools import RIGID, wrist_give

    tool = World(seed=0).cell.tool
    rigid = ArmPhysics()
    rigid.reset(np.zeros(6))
    assert wrist_give(rigid, 0.0, tool) == RIGID
    physics = ArmPhysics(
        [Effect("backlash", "q6", {"half_width": 0.05}), Effect("backlash", "q5", {"half_width": 0.05})]
    )
    physics.reset(np.zeros(6))
    physics.step([0, 0, 0, 0, 0.5, 0.5], 0.01)  # q5 and q6 trail below their commands
    minus_x, plus_x, minus_y, plus_y = wrist_give(physics, 0.0, tool)
    assert (minus_x, plus_x) == pytest.approx((0.0, 0.1 * tool.jaw_length))  # +q6 swings the tip along +x
    lever = tool.wrist_length + tool.jaw_length
    assert (minus_y, plus_y) == pytest.approx((0.1 * lever, 0.0))  # +q5 swings it along -y
    assert wrist_give(physics, np.pi / 2, tool)[2] == pytest.approx(
        0.1 * tool.wrist_length
    )  # jaw turned aside


@pytest.mark.parametrize("wrist_yaw", [0.0, -0.8])
def test_the_gives_directions_are_where_forward_kinematics_moves_the_tip(wrist_yaw):
    from pegbt.motion.kinematics import shaft_end_and_tip

    tool = World(seed=0).cell.tool
    q = np.array([0.8, 0.1, 0.2, 0.0, -0.1, wrist_yaw])
    _, tip = shaft_end_and_tip(q)
    for joint, expected in (
        (5, [tool.jaw_length, 0.0]),
        (4, [0.0, -(tool.wrist_length + tool.jaw_length * np.cos(wrist_yaw))]),
    ):
        nudged = q.copy()
        nudged[joint] += 1e-4
        moved = tip[:3, :3].T @ (shaft_end_and_tip(nudged)[1][:3, 3] - tip[:3, 3]) / 1e-4
        assert moved[:2] == pytest.approx(expected, abs=2e-4)
