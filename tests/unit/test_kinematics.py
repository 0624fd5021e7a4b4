"""Forward kinematics against the reference geometry's stated poses."""

import numpy as np

from pegbt.motion.kinematics import forward_kinematics, link_frames, shaft_end_and_tip


def test_home_configuration_points_the_tool_straight_down():
    T = forward_kinematics([0, 0, 0.15, 0, 0, 0])
    assert np.allclose(T[:3, 3], [0, 0, -0.153], atol=1e-12)
    assert np.allclose(T[:3, :3], np.eye(3), atol=1e-12)


def test_batches_keep_their_shape():
    q = np.tile([0.1, -0.2, 0.12, 0.3, 0.2, -0.1], (4, 3, 1))
    T = forward_kinematics(q)
    assert T.shape == (4, 3, 4, 4)
    assert np.allclose(T[2, 1], forward_kinematics(q[2, 1]))


def test_arm_limits_name_the_joint_that_is_out():
    from pegbt.motion.limits import arm_settings

    problems = arm_settings("PSM1").joint_violations([0, 0, 0.30, 0, 0, float("nan")])
    assert len(problems) == 2
    assert problems[0].startswith("q3 (insertion)") and "q6 (wrist_yaw) is nan" == problems[1]


def test_the_single_configuration_chain_matches_the_batched_one():
    rng = np.random.default_rng(4)
    for q in rng.uniform([-1.3, -1.0, 0.08, -1.7, -1.5, -1.7], [1.3, 1.0, 0.24, 1.7, 1.5, 1.7], (50, 6)):
        shaft_end, tip = shaft_end_and_tip(q)
        frames = link_frames(q)
        assert np.allclose(tip, frames[-1], atol=1e-12)
        assert np.allclose(shaft_end, frames[2][:3, 3], atol=1e-12)
