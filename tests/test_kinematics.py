"""Forward kinematics against the reference geometry's stated poses."""

import numpy as np

from pegbt.motion.kinematics import forward_kinematics


def test_home_configuration_points_the_tool_straight_down():
    T = forward_kinematics([0, 0, 0.15, 0, 0, 0])
    assert np.allclose(T[:3, 3], [0, 0, -0.153], atol=1e-12)
    assert np.allclose(T[:3, :3], np.eye(3), atol=1e-12)


def test_batches_keep_their_shape():
    q = np.tile([0.1, -0.2, 0.12, 0.3, 0.2, -0.1], (4, 3, 1))
    T = forward_kinematics(q)
    assert T.shape == (4, 3, 4, 4)
    assert np.allclose(T[2, 1], forward_kinematics(q[2, 1]))
