"""The dVRK's own figures for a PSM with a large needle driver, each from the file it is read from.

Paths are in jhu-dvrk/sawIntuitiveResearchKit unless another repository is named. The simulator's
`--interface dvrk` arm (`pegbt.sim.dvrk_arm`) clips, plans, faults and throttles by these numbers.
"""

from __future__ import annotations

import math

import numpy as np

from pegbt.motion.limits import ArmSettings

# Joint names of measured_js/setpoint_js: share/kinematic/PSM.json ("yaw", "pitch", "insertion") and the
# tool's share/tool/LARGE_NEEDLE_DRIVER_400006.json ("roll", "wrist_pitch", "wrist_yaw"); the jaw is "jaw"
# (core/components/code/mtsIntuitiveResearchKitPSM.cpp, ConfigureTool).
JOINT_NAMES = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
JAW_NAMES = ("jaw",)
# Until the tool engages, measured_js and setpoint_js carry the PID's seven joints, the tool's four as its
# actuators' discs (share/pid/sawControllersPID-PSM.json, "name"; mtsIntuitiveResearchKitArm.cpp
# `UpdateStateJointKinematics` copies the PID's joints when mtsIntuitiveResearchKitPSM.cpp's
# `is_cartesian_ready` is false).
PID_NAMES = ("yaw", "pitch", "insertion", "disc_1", "disc_2", "disc_3", "disc_4")

# Position limits ("qmin", "qmax"): share/kinematic/PSM.json for the first three joints,
# share/tool/LARGE_NEEDLE_DRIVER_400006.json for the tool's three and its "jaw".
LOWER = np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
UPPER = np.array([1.588, 0.925025, 0.24, 4.53786, 1.39626, 1.39626])
JAW_LOWER, JAW_UPPER = -0.698132, 1.39626

# move_jp's trajectory limits, joints then jaw: mtsIntuitiveResearchKitPSM.cpp, Init (m_trajectory_j.v_max
# and a_max: 90 deg/s and 90 deg/s^2 for yaw and pitch, 0.2 m/s and 0.2 m/s^2 for insertion, 3 x 360 deg/s and
# 2 x 360 deg/s^2 for the last four); the ratios default to 1 (mtsIntuitiveResearchKit.h, JointTrajectory).
_DEG = math.pi / 180.0
TRAJECTORY_VELOCITY = np.array(
    [90 * _DEG, 90 * _DEG, 0.2, 1080 * _DEG, 1080 * _DEG, 1080 * _DEG, 1080 * _DEG]
)
TRAJECTORY_ACCELERATION = np.array(
    [90 * _DEG, 90 * _DEG, 0.2, 720 * _DEG, 720 * _DEG, 720 * _DEG, 720 * _DEG]
)

# Tracking-error tolerance of each actuator ("p_measured_setpoint_tolerance"): share/pid/sawControllersPID-PSM.json.
# The PID checks |set-point - measured| per actuator (jhu-saw/sawControllers core/components/code/mtsPID.cpp).
ACTUATOR_TOLERANCE = np.array([0.5, 0.5, 0.05, 0.6, 0.6, 0.6, 0.6])

# The tool's coupling, actuators to joints (roll, wrist pitch, wrist yaw, jaw):
# share/tool/LARGE_NEEDLE_DRIVER_400006.json, "coupling"/"ActuatorToJointPosition".
TOOL_ACTUATOR_TO_JOINT = np.array(
    [
        [-1.5632, 0.0, 0.0, 0.0],
        [0.0, 1.0186, 0.0, 0.0],
        [0.0, -0.8306, 0.6089, 0.6089],
        [0.0, 0.0, -1.2177, 1.2177],
    ]
)

# Homing: goal tolerance 3 degrees (mtsIntuitiveResearchKitPSM.cpp, Init, goal_tolerance) and 2 s past the
# trajectory's end before a FAULT (mtsIntuitiveResearchKitArm.cpp, RunHoming, extraTime).
HOMING_TOLERANCE = math.radians(3.0)
HOMING_EXTRA_TIME = 2.0

# Encoders are biased from the potentiometers over 1970 samples of the IO loop
# (mtsIntuitiveResearchKitArm.cpp, EnterCalibratingEncodersFromPots) at IOPeriod = 1/1500 s - 0.06 ms
# (core/components/include/sawIntuitiveResearchKit/mtsIntuitiveResearchKit.h).
ENCODER_BIAS_TIME = 1970 * (1.0 / 1500.0 - 0.06e-3)

# Power-on: the dVRK waits for the amplifiers up to 2 x TimeToPower (3 s, mtsIntuitiveResearchKit.h) and the
# time they take is the hardware's; the simulated amplifiers take this long.
POWER_ON_TIME = 0.5

# "arm not ready" warnings: at most one every 2 s (mtsIntuitiveResearchKitArm.cpp, ArmIsReady).
NOT_READY_THROTTLE = 2.0

# The CRTK bridge publishes every 10 ms by default (jhu-cisst/cisst-ros cisst_ros_crtk/include/cisst_ros_crtk/
# cisst_ros_crtk.h, bridge_provided_default_publish_period; ros/dvrk_robot/src/dvrk_system.cpp, --ros-period).
PUBLISH_PERIOD = 0.01


_JOINT_TO_ACTUATOR = np.linalg.inv(TOOL_ACTUATOR_TO_JOINT)


def actuator_errors(joint_errors: np.ndarray) -> np.ndarray:
    """Set-point minus measured of the seven actuators, from that of the six joints and the jaw (7,)."""
    return pid_positions(joint_errors)


def pid_positions(joints: np.ndarray) -> np.ndarray:
    """The PID's seven positions (three joints, then the tool's four actuators) of the six joints and the jaw."""
    return np.concatenate([joints[:3], _JOINT_TO_ACTUATOR @ joints[3:7]])


def clip_bounds(settings: ArmSettings) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Joint and jaw bounds a command is clipped to: pegbt's limits (`skills/psm.yaml`) where they are
    narrower, never wider than the dVRK's own."""
    return (
        np.maximum(settings.lower, LOWER),
        np.minimum(settings.upper, UPPER),
        max(settings.jaw_lower, JAW_LOWER),
        min(settings.jaw_upper, JAW_UPPER),
    )
