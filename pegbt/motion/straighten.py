"""Joint configurations turned upright: the same tip position and heading, the tool's axis exactly along
the pegs' axis. The SQP starts from the warm path's control points turned upright this way.

Why: a joint-space spline between waypoints of different roll (an approach that turns the jaw by 60°
to meet its next block) leans the tool by 10-20° in transit. From there the trust region cannot bring
the tool back within its 2° in one linearisation, the first QP is infeasible and the refinement gives
up. Started upright, it keeps the cone from the first QP on (measured over 363 transfers of
unilateral, bilateral and handover trials: from the leaning path 10 gave up, from the upright one none,
at the same durations).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pegbt.motion.channel import Upright
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import ArmSettings

INSERTION = 2  # the one prismatic joint: a length, not an angle to unwrap


def upright_configurations(
    q: NDArray[np.float64], settings: ArmSettings, upright: Upright
) -> NDArray[np.float64]:
    """`q` (K, 6) with each configuration replaced by the IK of its tip pose turned upright (tip position
    and heading about the axis kept), each angle taken within ±π of its old value. A configuration
    whose upright pose is out of reach or out of the joint limits is kept as it is."""
    pose = forward_kinematics(q)
    up = upright.axis
    heading = pose[:, :3, 0] - np.multiply.outer(pose[:, :3, 0] @ up, up)
    heading /= np.linalg.norm(heading, axis=1, keepdims=True)
    target = pose.copy()
    target[:, :3, 0], target[:, :3, 1], target[:, :3, 2] = heading, np.cross(up, heading), up
    solution = inverse_kinematics(target)
    near = q + np.remainder(solution.q - q + np.pi, 2 * np.pi) - np.pi
    near[:, INSERTION] = solution.q[:, INSERTION]
    ok = solution.reachable & np.all((near >= settings.lower) & (near <= settings.upper), axis=1)
    return np.where(ok[:, None], near, q)
