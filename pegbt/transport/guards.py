"""Checks on joint commands, shared by the client (refuse before sending) and the simulator (refuse on arrival).

Each check returns the list of problems in words; an empty list means the command may be sent or
applied. A command is never clipped into range: it is refused whole.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.psm import N_JOINTS, joint_label

# Relative slack on velocity checks, for floating-point round-off in planners' samples.
VELOCITY_SLACK = 1e-6


class CommandRefused(PegbtError):
    """A command that would be NaN, the wrong size, or outside joint or velocity limits."""


def joint_problems(q: ArrayLike, settings: ArmSettings) -> list[str]:
    """Size, finiteness and joint limits of one 6-joint position vector."""
    q = np.asarray(q, dtype=float).reshape(-1)
    if q.shape != (N_JOINTS,):
        return [f"expected {N_JOINTS} joint positions, got {q.size}"]
    return settings.joint_violations(q)


def step_problems(q: ArrayLike, reference: ArrayLike, settings: ArmSettings, seconds: float) -> list[str]:
    """Joints that would move from `reference` to `q` in `seconds` faster than their velocity limits."""
    q, reference = np.asarray(q, dtype=float), np.asarray(reference, dtype=float)
    speed = np.abs(q - reference) / seconds
    allowed = settings.velocity * (1 + VELOCITY_SLACK)
    return [
        f"{joint_label(int(i))} would move at {speed[i]:.4g}/s, limit {settings.velocity[i]:.4g}/s"
        for i in np.flatnonzero(speed > allowed)
    ]


def jaw_problems(angle: ArrayLike, settings: ArmSettings) -> list[str]:
    """Size, finiteness and limits of one jaw angle."""
    values = np.asarray(angle, dtype=float).reshape(-1)
    if values.shape != (1,):
        return [f"expected 1 jaw angle, got {values.size}"]
    value = float(values[0])
    if not np.isfinite(value):
        return [f"jaw angle is {value}"]
    if not settings.jaw_lower <= value <= settings.jaw_upper:
        return [f"jaw angle {value:.4f} outside [{settings.jaw_lower:.4f}, {settings.jaw_upper:.4f}]"]
    return []


def jaw_step_problems(angle: float, reference: float, settings: ArmSettings, seconds: float) -> list[str]:
    """Why moving the jaw from `reference` to `angle` in `seconds` breaks its velocity limit (empty if not).

    Shared by the client (refuses before sending) and the simulator (refuses what arrives), so both hold
    a streamed jaw command to the same limit."""
    speed = abs(angle - reference) / seconds
    if speed > settings.jaw_velocity * (1 + VELOCITY_SLACK):
        return [f"jaw would move at {speed:.4g} rad/s, limit {settings.jaw_velocity:.4g} rad/s"]
    return []


def trajectory_problems(trajectory: Any, settings: ArmSettings) -> list[str]:
    """Shape, time order, joint limits and velocity limits (given and implied) of a whole trajectory."""
    t = np.asarray(trajectory.t, dtype=float).reshape(-1)
    q = np.asarray(trajectory.q, dtype=float)
    if q.ndim != 2 or q.shape != (len(t), N_JOINTS) or len(t) == 0:
        return [f"trajectory must have N times and N×{N_JOINTS} positions, got {t.shape} and {q.shape}"]
    if not np.all(np.isfinite(t)) or t[0] < 0 or np.any(np.diff(t) <= 0):
        return ["trajectory times must be finite, >= 0 and strictly increasing"]
    outside = ~np.isfinite(q) | (q < settings.lower) | (q > settings.upper)
    problems = _first_bad_row(q, outside, lambda row: joint_problems(row, settings), "point")
    velocities = [("velocity at point", getattr(trajectory, "qd", None))]
    if len(t) > 1:
        velocities.append(("segment after point", np.diff(q, axis=0) / np.diff(t)[:, None]))
    for what, v in velocities:
        if v is None or problems:
            continue
        v = np.asarray(v, dtype=float)
        if v.ndim != 2 or v.shape[1] != N_JOINTS or (what.startswith("velocity") and v.shape != q.shape):
            problems.append(f"trajectory velocities must be shaped {q.shape}, got {v.shape}")
            continue
        too_fast = ~np.isfinite(v) | (np.abs(v) > settings.velocity * (1 + VELOCITY_SLACK))
        problems += _first_bad_row(v, too_fast, lambda row: _speed_problems(row, settings), what)
    return problems


def _speed_problems(v: NDArray[np.float64], settings: ArmSettings) -> list[str]:
    if not np.all(np.isfinite(v)):
        return [f"velocity is {v.tolist()}"]
    return step_problems(v, np.zeros(N_JOINTS), settings, 1.0)


def _first_bad_row(rows: NDArray[np.float64], bad: NDArray[np.bool_], check: Any, what: str) -> list[str]:
    """Problems of the first offending row only, named by its index (a 500-point plan fails once, clearly)."""
    offending = np.flatnonzero(bad.any(axis=1))
    if not len(offending):
        return []
    index = int(offending[0])
    return [f"{what} {index}: {problem}" for problem in check(rows[index])]


def refuse_if(problems: list[str], what: str, field: str) -> None:
    """Raise `CommandRefused` listing `problems`, if any."""
    if problems:
        raise CommandRefused(f"{what} refused: {'; '.join(problems)}", field=field)
