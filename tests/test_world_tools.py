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
    assert tool.tip[:3, 2] == pytest.approx([0, 0, -1], abs=0.03)  # tool-tip z points back up, out of the board
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
    assert np.linalg.norm((invert_rigid(world.blocks[1].pose) @ tool.tip)[:3, 3] - candidates.positions[0]) < 1e-9
    world.update(0.01, {"PSM1": tool})
    events = world.update(0.02, {"PSM1": _tool(world, q, motion_settings().transfer.jaw_closed)})
    assert [event.kind for event in events] == (["grasp"] if grips else ["grasp_miss"])
    if grips:
        assert world.jaw_stop("PSM1") == pytest.approx(2 * np.arcsin(0.001 / 0.0095))
    else:
        assert world.jaw_stop("PSM1") is None


def test_the_wrist_gives_within_the_cable_play_the_physics_names():
    from pegbt.physics import ArmPhysics, Effect
    from pegbt.sim.tools import wrist_give

    tool = World(seed=0).cell.tool
    assert wrist_give(ArmPhysics(), 0.0, tool) == (0.0, 0.0)  # ideal cables: a rigid wrist
    physics = ArmPhysics([
        Effect("backlash", "q6", {"half_width": 0.05}),
        Effect("hysteresis", "q5", {"source": "q5", "half_width": 0.2, "k": 0.25}),
        Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.3, "k": -0.5}),  # another drive's play: no give
    ])
    assert physics.play("q6") == pytest.approx(0.05) and physics.play("q5") == pytest.approx(0.05)
    along_x, along_y = wrist_give(physics, 0.0, tool)
    assert along_x == pytest.approx(0.05 * tool.jaw_length)  # yaw swings the tip on the jaw
    assert along_y == pytest.approx(0.05 * (tool.wrist_length + tool.jaw_length))  # pitch on wrist and jaw
    assert wrist_give(physics, np.pi / 2, tool)[1] == pytest.approx(0.05 * tool.wrist_length)  # jaw turned aside
