"""The reference paper's hand-eye registration, made with the uncalibrated arm it registers.

The paper's robot found each arm's base in the camera's frame by moving that arm, uncalibrated, to 100
random positions of its wrist's pitch axis (q4–q6 at zero, `set_joint_interpolate`, 0.3 s to settle),
finding the pitch axis's balls in the camera's cloud and fitting one rigid transform from where the camera
saw it to where the encoders' forward kinematics put it (`calibration_files/script/calibration_dvrk_RGBD.py`,
BerkeleyAutomation/FLSpegtransferHO, `use_Trc = False`). That transform absorbs the part of the arm's cable
error that is rigid over the workspace (an offset of q1 or q2 is most of it), so the paper's uncalibrated
arm missed only by the rest: by arm, the static errors differ (`dvrk-real`'s PSM1 and PSM2), and so does
what the registration leaves. The simulated arm is registered the same way here, with its `dvrk-real`
physics: the transform is where the registered robot believes its base stands.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from pegbt.frames import invert_rigid
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.kinematics import shaft_end_and_tip
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import DEFAULT_JOINTS, SimArm
from pegbt.workcell import workcell

SAMPLES = 100  # positions the paper's script visits per arm
SETTLE_S = 0.3  # s the paper's script waits at each before the camera captures
# m above the peg tops, the tip's (its pitch axis a wrist above): the paper's boxes are 17–39 mm tall
HEIGHT = (0.0, 0.03)
SEED = 2022  # one registration per arm, as the paper made once for all its trials
# m, the arm's frame: the paper's two-arm scripts move PSM2's registration by hand before every trial
# (`Trc2[:3, -1] += [-0.001, 0, 0]`, `FLSPegTransfer_dual.py` and `FLSPegTransfer_handover.py`); the
# one-arm script loads PSM1's as fitted (`FLSPegTransfer_single.py`)
HAND_ADJUSTMENT = {"PSM1": np.zeros(3), "PSM2": np.array([-0.001, 0.0, 0.0])}


def _targets(arm: str, rng: np.random.Generator) -> NDArray[np.float64]:
    """(SAMPLES, 6) joints: the tool straight down over random points of the board's span, its pitch
    axis where q1–q3 put it and q4–q6 at zero, as the paper's script commands them."""
    cell = workcell()
    tops = cell.peg_tops_in(arm)
    up = cell.up_in(arm)
    low, high = tops.min(axis=0), tops.max(axis=0)
    points = rng.uniform(low, high, (SAMPLES, 3)) + np.outer(rng.uniform(*HEIGHT, SAMPLES), up)
    poses = np.tile(np.eye(4), (SAMPLES, 1, 1))
    poses[:, :3, 2] = up  # tool z back up along the pegs
    poses[:, :3, 0] = np.cross([0.0, 1.0, 0.0], up) / np.linalg.norm(np.cross([0.0, 1.0, 0.0], up))
    poses[:, :3, 1] = np.cross(up, poses[0, :3, 0])
    poses[:, :3, 3] = points
    ik = inverse_kinematics(poses, arm_settings(arm))
    q = ik.q[ik.ok].copy()
    q[:, 3:] = 0.0
    return q


def _rigid(source: NDArray[np.float64], target: NDArray[np.float64]) -> NDArray[np.float64]:
    """(4, 4) the least-squares rigid transform taking the points `source` onto `target` (Kabsch)."""
    centre_s, centre_t = source.mean(axis=0), target.mean(axis=0)
    rotation, _ = Rotation.align_vectors(target - centre_t, source - centre_s)
    transform = np.eye(4)
    transform[:3, :3] = rotation.as_matrix()
    transform[:3, 3] = centre_t - transform[:3, :3] @ centre_s
    return transform


@cache
def registered_arm_from_board(arm: str, physics: str) -> NDArray[np.float64]:
    """(4, 4) board to `arm`'s base frame as the paper's registration finds it for an arm with `physics`
    (the camera, registered to the board, sees the physical pitch axis; the encoders say the commanded),
    with the paper's hand adjustment."""
    cell = workcell()
    settings = arm_settings(arm)
    sim = SimArm(arm, settings, ArmPhysics.load(physics, arm), q0=DEFAULT_JOINTS)
    seen, commanded = [], []
    for goal in _targets(arm, np.random.default_rng([SEED, int(arm[-1])])):
        sim.move_jp(goal, "registration")
        while sim.is_busy:
            sim.advance(sim.period)
        for _ in range(round(SETTLE_S / sim.period)):
            sim.advance(sim.period)
        seen.append(shaft_end_and_tip(sim.physical)[0])
        commanded.append(shaft_end_and_tip(sim.joints.encoder)[0])
    board = invert_rigid(cell.board_to_arm(arm))
    seen_in_board = np.array(seen) @ board[:3, :3].T + board[:3, 3]
    registered = _rigid(seen_in_board, np.array(commanded))
    registered[:3, 3] += HAND_ADJUSTMENT[arm]
    return registered


def registered_arm_to_board(arm: str, physics: str, truth: NDArray[np.float64]) -> NDArray[np.float64]:
    """(4, 4) where `arm`'s base effectively stands for a robot that plans by the work cell's figures
    (`Workcell.board_to_arm`) although it was registered as the paper's was: a target planned at `x` in
    the board frame is commanded at `R·x` by the registered robot, the same as `A·x` by one whose base
    stands at `truth·R·A⁻¹` (`truth`: where the base truly stands, `World.arm_to_board`)."""
    nominal = workcell().board_to_arm(arm)
    return truth @ registered_arm_from_board(arm, physics) @ invert_rigid(nominal)
