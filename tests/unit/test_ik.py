"""Closed-form IK against the forward kinematics, and the geometric Jacobian against finite differences."""

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.motion.ik import inverse_kinematics, solve_ik
from pegbt.motion.jacobian import jacobian
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings

PSM1 = arm_settings("PSM1")


def _rotation_angle(Ra, Rb):
    cos = (np.trace(np.swapaxes(Ra, -1, -2) @ Rb, axis1=-2, axis2=-1) - 1) / 2
    sin = np.linalg.norm(np.swapaxes(Ra, -1, -2) @ Rb - Rb.swapaxes(-1, -2) @ Ra, axis=(-2, -1)) / (
        2 * np.sqrt(2)
    )
    return np.arctan2(sin, cos)


def _random_configurations(n, seed=0):
    return np.random.default_rng(seed).uniform(PSM1.lower, PSM1.upper, (n, 6))


def test_fk_of_ik_reproduces_thousands_of_random_poses():
    q = _random_configurations(5000)
    target = forward_kinematics(q)
    solution = inverse_kinematics(target, PSM1)
    assert solution.ok.all()
    reached = forward_kinematics(solution.q)
    assert np.abs(reached[:, :3, 3] - target[:, :3, 3]).max() < 1e-9
    assert _rotation_angle(reached[:, :3, :3], target[:, :3, :3]).max() < 1e-9
    # Inside the limits the solution is unique, so IK also returns the joints that made the pose.
    assert np.abs(solution.q - q).max() < 1e-9


def test_single_pose_path_agrees_with_the_batch():
    q = _random_configurations(20, seed=1)
    target = forward_kinematics(q)
    batch = inverse_kinematics(target, PSM1).q
    for i in range(len(q)):
        single = inverse_kinematics(target[i], PSM1)
        assert single.ok and single.q.shape == (6,)
        assert np.allclose(single.q, batch[i], atol=1e-12)


def test_batches_of_any_shape():
    q = _random_configurations(12, seed=2).reshape(3, 4, 6)
    solution = inverse_kinematics(forward_kinematics(q), PSM1)
    assert solution.q.shape == (3, 4, 6) and solution.ok.shape == (3, 4)
    assert np.allclose(solution.q, q, atol=1e-9)


def test_out_of_limit_pose_is_refused_naming_the_limit():
    q = np.array(
        [[0.1, 0.2, 0.26, 0.0, 0.1, 0.1], [0.1, 0.2, 0.15, 0.0, 0.1, 0.1]]
    )  # first: insertion too deep
    solution = inverse_kinematics(forward_kinematics(q), PSM1)
    assert solution.reachable.all()
    assert solution.ok.tolist() == [False, True]
    assert solution.problems(0)[0].startswith("q3 (insertion) = 0.2600 outside [0.0800, 0.2400]")
    assert solution.problems(1) == []
    with pytest.raises(PegbtError, match=r"grasp waypoint: not reachable by PSM1: q3 \(insertion\)"):
        solve_ik(forward_kinematics(q[0]), PSM1, what="grasp waypoint")


def test_wrist_limit_is_named():
    q = np.array([0.1, 0.2, 0.15, 0.0, 0.1, 1.9])  # wrist yaw beyond 80°
    with pytest.raises(PegbtError, match=r"q6 \(wrist_yaw\)"):
        solve_ik(forward_kinematics(q), PSM1)


def test_nan_and_non_rigid_poses_are_unreachable():
    good = forward_kinematics([0.1, 0.2, 0.15, 0.0, 0.1, 0.1])
    nan = good.copy()
    nan[0, 3] = np.nan
    sheared = good.copy()
    sheared[0, 1] += 0.1
    solution = inverse_kinematics(np.stack([nan, sheared, good]), PSM1)
    assert solution.reachable.tolist() == [False, False, True]
    assert solution.problems(0) == ["the pose has non-finite entries"]
    assert solution.problems(1) == ["the pose's rotation is not orthonormal"]
    for pose, reason in ((nan, "non-finite"), (sheared, "not orthonormal")):
        single = inverse_kinematics(pose, PSM1)
        assert not single.ok and reason in single.problems()[0]
        with pytest.raises(PegbtError, match=reason):
            solve_ik(pose, PSM1)


def test_pose_far_outside_the_workspace_names_the_insertion_limit():
    pose = np.eye(4)
    pose[:3, 3] = [0.0, 0.0, -0.5]  # half a metre below the RCM: needs far more insertion than the tool has
    with pytest.raises(PegbtError, match=r"q3 \(insertion\) = .* outside"):
        solve_ik(pose, PSM1, what="waypoint 2")


def test_jacobian_matches_finite_differences():
    q = _random_configurations(50, seed=3)
    J = jacobian(q)
    eps = 1e-7
    for j in range(6):
        step = np.zeros(6)
        step[j] = eps
        plus, minus = forward_kinematics(q + step), forward_kinematics(q - step)
        linear = (plus[:, :3, 3] - minus[:, :3, 3]) / (2 * eps)
        dR = (plus[:, :3, :3] - minus[:, :3, :3]) / (2 * eps)
        skew = dR @ np.swapaxes(forward_kinematics(q)[:, :3, :3], -1, -2)
        angular = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=-1)
        assert np.abs(J[:, :3, j] - linear).max() < 1e-7
        assert np.abs(J[:, 3:, j] - angular).max() < 1e-7
