"""Every sampled trajectory is checked before it may be streamed: joint, velocity and acceleration
limits, the peg channel (the tip on the peg's axis, the tool not turning the block's hole off it), the
block's clearance over the pegs between its two channels, the upright tool while it carries a block, and
C1 continuity (no jump in position or velocity between set-points)."""

from __future__ import annotations

import numpy as np

from pegbt.errors import PegbtError
from pegbt.motion.channel import Channel, Upright
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import ArmSettings
from pegbt.motion.trajectory import Trajectory
from pegbt.psm import joint_label

CLEARANCE_SLACK = (
    0.0005  # m the tip may sag below the clearing height in transit (the channel margin is 2.8 mm)
)
RELATIVE_SLACK = 1e-6  # rounding allowed on velocity and acceleration limits
ABSOLUTE_SLACK = 1e-9


def _limit_problems(trajectory: Trajectory, settings: ArmSettings) -> list[str]:
    problems = []
    t, q, qd, qdd = trajectory.t, trajectory.q, trajectory.qd, trajectory.qdd
    for name, values, low, high in (
        ("position", q, settings.lower - ABSOLUTE_SLACK, settings.upper + ABSOLUTE_SLACK),
        (
            "velocity",
            qd,
            -settings.planner_velocity * (1 + RELATIVE_SLACK),
            settings.planner_velocity * (1 + RELATIVE_SLACK),
        ),
        (
            "acceleration",
            qdd,
            -settings.planner_acceleration * (1 + RELATIVE_SLACK),
            settings.planner_acceleration * (1 + RELATIVE_SLACK),
        ),
    ):
        bad = ~((values >= low) & (values <= high))  # also catches NaN
        for j in np.flatnonzero(bad.any(axis=0)):
            k = int(np.argmax(bad[:, j]))
            problems.append(
                f"{joint_label(int(j))} {name} {values[k, j]:.4g} at t={t[k]:.2f} s outside [{low[j]:.4g}, {high[j]:.4g}]"
            )
    return problems


def _continuity_problems(trajectory: Trajectory, settings: ArmSettings) -> list[str]:
    problems = []
    t, q, qd = trajectory.t, trajectory.q, trajectory.qd
    dt = np.diff(t)
    if np.any(np.abs(dt - settings.control_period) > 1e-9):
        problems.append(f"set-points are not {settings.control_period * 1000:g} ms apart")
    if np.any(np.abs(qd[0]) > ABSOLUTE_SLACK) or np.any(np.abs(qd[-1]) > ABSOLUTE_SLACK):
        problems.append("does not start and end at rest")
    a = settings.planner_acceleration * (1 + RELATIVE_SLACK)
    # With |q̈| ≤ a, velocity moves at most a·dt per step and position departs from the trapezoid of the
    # velocities by at most a·dt²/4: anything more is a jump.
    velocity_jump = np.abs(np.diff(qd, axis=0)) > a * dt[:, None] + ABSOLUTE_SLACK
    position_jump = (
        np.abs(np.diff(q, axis=0) - dt[:, None] * (qd[1:] + qd[:-1]) / 2)
        > a * dt[:, None] ** 2 / 4 + ABSOLUTE_SLACK
    )
    for kind, jumps in (("velocity", velocity_jump), ("position", position_jump)):
        for j in np.flatnonzero(jumps.any(axis=0)):
            problems.append(f"{joint_label(int(j))} {kind} jumps at t={t[int(np.argmax(jumps[:, j]))]:.2f} s")
    return problems


def _channel_problems(tips: np.ndarray, tool_x: np.ndarray, channel: Channel, leaving: bool) -> list[str]:
    """The tip off the channel's line, or the tool turned about it by more than `max_twist` from the
    channel's end (the start's, leaving; the goal's, arriving), while the block is on the peg."""
    heights = channel.height(tips)
    above = heights >= channel.clear
    if not above.any():
        return [f"the block never clears the {'start' if leaving else 'goal'} peg"]
    on_peg = (
        np.arange(len(tips)) < int(np.argmax(above))
        if leaving
        else np.arange(len(tips)) > len(tips) - 1 - int(np.argmax(above[::-1]))
    )
    peg = "start" if leaving else "goal"
    excess = channel.distance(tips[on_peg]) - channel.allowed(heights[on_peg])
    if excess.size and excess.max() > 0:
        worst = int(np.argmax(excess))
        return [
            f"leaves the {peg} peg's axis by {channel.distance(tips[on_peg][worst]) * 1000:.2f} mm "
            f"(channel tolerance {channel.allowed(heights[on_peg][worst]) * 1000:.2f} mm)"
        ]
    twist = np.abs(channel.twist(tool_x[on_peg], tool_x[0 if leaving else -1]))
    if twist.size and twist.max() > channel.max_twist + ABSOLUTE_SLACK:
        return [
            f"turns the block's hole {twist.max() * channel.lever * 1000:.2f} mm round the tip on the {peg} peg (channel tolerance {channel.tolerance * 1000:.2f} mm)"
        ]
    return []


def _clearance_problems(tips: np.ndarray, leaving: Channel | None, arriving: Channel) -> list[str]:
    """Between leaving the start peg's channel (from the first sample without one) and entering the goal
    peg's, the tip stays above both clearing heights: the block hangs clear of every peg top it passes
    (above the goal's alone after a jaw's way out of a held block's hole, not a `floor`). A
    goal in the air (a clearing height at or below it, or a goal that is no floor: the handover's meeting
    point, which the block comes up onto) sets none: from the start peg, the tip stays above its clearing
    height to the end."""
    if arriving.in_the_air:
        return [] if leaving is None else _clearance_to_the_air(tips, leaving)
    heights = arriving.height(tips)
    above = heights >= arriving.clear
    if not above.any():
        return []  # reported by the goal channel's check
    start = 0
    if leaving is not None:
        left = leaving.height(tips) >= leaving.clear
        if not left.any():
            return []  # reported by the start channel's check
        start = int(np.argmax(left))
    end = len(tips) - 1 - int(np.argmax(above[::-1]))
    if end <= start:
        return []
    floor = np.full(end + 1 - start, arriving.clear)
    if leaving is not None and leaving.floor:
        floor = np.maximum(floor, leaving.clear + float((leaving.point - arriving.point) @ arriving.axis))
    return _sag_problems(floor - heights[start : end + 1], "the clearing height between the pegs")


def _clearance_to_the_air(tips: np.ndarray, leaving: Channel) -> list[str]:
    """From leaving the start peg's channel to a goal in the air, the tip stays above that peg's clearing
    height: the block hangs clear of the pegs it passes on its way up to the meeting point."""
    left = leaving.height(tips) >= leaving.clear
    if not left.any():
        return []  # reported by the start channel's check
    sag = leaving.clear - leaving.height(tips[int(np.argmax(left)) :])
    return _sag_problems(sag, "the start peg's clearing height on its way")


def _sag_problems(sag: np.ndarray, below: str) -> list[str]:
    """The worst of `sag` (m under a clearing height, per sample) if it is beyond `CLEARANCE_SLACK`."""
    worst = float(np.max(sag))
    if worst > CLEARANCE_SLACK:
        return [f"the tip sags {worst * 1000:.2f} mm below {below} (allowed {CLEARANCE_SLACK * 1000:.2f} mm)"]
    return []


def _upright_problems(t: np.ndarray, tool_axes: np.ndarray, upright: Upright) -> list[str]:
    tilt = upright.tilt(tool_axes)
    worst = int(np.argmax(tilt))
    if tilt[worst] > upright.max_tilt + ABSOLUTE_SLACK:
        return [
            f"the tool leans {np.degrees(tilt[worst]):.2f}° from the pegs' axis at t={t[worst]:.2f} s (upright limit {np.degrees(upright.max_tilt):.2f}°)"
        ]
    return []


def trajectory_problems(
    trajectory: Trajectory,
    settings: ArmSettings,
    *,
    leaving: Channel | None = None,
    arriving: Channel | None = None,
    upright: Upright | None = None,
) -> list[str]:
    """Everything wrong with `trajectory` for `settings`' arm; `leaving`/`arriving` are the channels the
    tip must follow from the start until the block clears it, and from entering it to the end;
    `upright` is how far the tool may lean, all along, while it carries the block."""
    problems = _limit_problems(trajectory, settings) + _continuity_problems(trajectory, settings)
    if leaving is not None or arriving is not None or upright is not None:
        poses = forward_kinematics(trajectory.q)
        tips, tool_x = poses[:, :3, 3], poses[:, :3, 0]
        if leaving is not None:
            problems += _channel_problems(tips, tool_x, leaving, leaving=True)
        if arriving is not None:
            problems += _channel_problems(tips, tool_x, arriving, leaving=False)
            problems += _clearance_problems(tips, leaving, arriving)
        if upright is not None:
            problems += _upright_problems(trajectory.t, poses[:, :3, 2], upright)
    return problems


def check_trajectory(
    trajectory: Trajectory,
    settings: ArmSettings,
    *,
    leaving: Channel | None = None,
    arriving: Channel | None = None,
    upright: Upright | None = None,
    what: str = "trajectory",
) -> Trajectory:
    """`trajectory` if it passes every check, else a `PegbtError` naming `what` and each violation."""
    problems = trajectory_problems(trajectory, settings, leaving=leaving, arriving=arriving, upright=upright)
    if problems:
        raise PegbtError(f"{what} for {settings.name} fails its checks: " + "; ".join(problems), field=what)
    return trajectory
