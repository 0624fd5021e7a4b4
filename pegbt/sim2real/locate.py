"""Locate a mismatch: per joint, how large, where in time, and in which motion regime.

The regimes are the signatures of the candidate physics, measured without fitting anything: error that
rises just after a joint reverses (play), a bias that flips with a joint's direction of motion
(hysteresis, backlash), error that grows with speed (lag, delay), a bias that drifts with the joint's
position (scale), and error that appears when *other* joints move (coupling).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.physics.kernels import play_grid
from pegbt.psm import JOINT_NAMES
from pegbt.scratch import ROWS, scratch, scratch_where

Array = NDArray[np.float64]

WINDOW_FRACTION = 0.02  # width of the moving window that finds where error concentrates
WINDOW_THRESHOLD = 2.0  # a window is kept where the local mean square exceeds this × the joint's
MAX_WINDOWS = 5
MAX_REGIMES = 5
AFTER_REVERSAL_S = 0.3  # streams: how long "just after a reversal" lasts
AFTER_REVERSAL_SAMPLES = 2  # set-points: how many samples
NOTABLE = 0.2  # report a regime when it changes the RMSE by 20 % or shifts the bias by 20 % of the RMSE


@dataclass(frozen=True)
class Regime:
    """Error inside a motion regime against outside it."""

    regime: str
    fraction: float
    rmse_in: float
    rmse_out: float
    bias_in: float
    bias_out: float

    @property
    def strength(self) -> float:
        ratio = abs(np.log(max(self.rmse_in, 1e-300) / max(self.rmse_out, 1e-300)))
        scale = max(np.hypot(self.rmse_in, self.rmse_out), 1e-300)
        return float(max(ratio, abs(self.bias_in - self.bias_out) / scale))

    def to_dict(self) -> dict[str, float | str]:
        return {
            "regime": self.regime,
            "fraction": self.fraction,
            "rmse_in": self.rmse_in,
            "rmse_out": self.rmse_out,
            "bias_in": self.bias_in,
            "bias_out": self.bias_out,
        }


@dataclass(frozen=True)
class JointMismatch:
    joint: str
    rmse: float
    bias: float
    share: float
    windows: list[tuple[float, float, float]]  # (t0, t1, share of this joint's squared error)
    regimes: list[Regime]

    def to_dict(self) -> dict:
        return {
            "joint": self.joint,
            "rmse": self.rmse,
            "bias": self.bias,
            "share": self.share,
            "windows": [[t0, t1] for t0, t1, _ in self.windows],
            "window_shares": [share for _, _, share in self.windows],
            "regimes": [regime.to_dict() for regime in self.regimes],
        }


def locate(residual: Array, q_cmd: Array, times: Array, is_stream: bool) -> list[JointMismatch]:
    """Per-joint size, windows and regimes of the residual (real − sim)."""
    mse = np.square(residual, out=scratch(residual.shape)).mean(0)
    total = float(mse.sum()) or 1.0
    motion = _motion(q_cmd, times, is_stream)
    return [
        JointMismatch(
            JOINT_NAMES[j],
            float(np.sqrt(mse[j])),
            float(residual[:, j].mean()),
            float(mse[j] / total),
            _windows(residual[:, j], times),
            _regimes(j, residual[:, j], q_cmd, motion),
        )
        for j in range(residual.shape[1])
    ]


def _windows(r: Array, times: Array) -> list[tuple[float, float, float]]:
    """Stretches where the local mean square error exceeds the joint's by WINDOW_THRESHOLD."""
    n = len(r)
    width = max(3, int(WINDOW_FRACTION * n))
    energy = np.square(r, out=scratch((n,)))
    total = float(energy.sum())
    if total == 0:
        return []
    hot = np.zeros(n + 2, dtype=bool)  # padded by a cold sample at each end
    hot[1:-1] = np.convolve(energy, np.ones(width) / width, mode="same") > WINDOW_THRESHOLD * energy.mean()
    edges = np.flatnonzero(hot[1:] != hot[:-1])
    runs = [[a, b] for a, b in zip(edges[::2], edges[1::2])]
    merged: list[list[int]] = []
    for run in runs:
        if merged and run[0] - merged[-1][1] < width:
            merged[-1][1] = run[1]
        else:
            merged.append(run)
    found = [(float(times[a]), float(times[b - 1]), float(energy[a:b].sum() / total)) for a, b in merged]
    return sorted(found, key=lambda w: -w[2])[:MAX_WINDOWS]


@dataclass(frozen=True)
class _Motion:
    """Each joint's motion regimes as masks (N, J), a byte a sample each: as float arrays of directions,
    speeds and the other joints' motion they were 0.3 kB a sample, more than the recording itself."""

    rising: NDArray[np.bool_]  # the joint's last move was up (the step into the sample, carried)
    after_reversal: NDArray[np.bool_]
    fast: NDArray[np.bool_]  # top third of the joint's speeds
    others_moving: NDArray[np.bool_]  # the other joints move more than usual


def _motion(q_cmd: Array, times: Array, is_stream: bool) -> _Motion:
    """The masks, found `ROWS` samples at a time from the state the chunk before left (play's last output,
    the last move, a reversal's hold running on); what is read whole (a median, a percentile, the summed
    motion) is in scratch (`pegbt.scratch`): it holds the masks, not the recording's length in floats."""
    n, joints = q_cmd.shape
    dt = scratch((n,))
    dt[0] = times[0] - (times[0] - (times[1] - times[0]))  # as `np.diff(times, prepend=...)` gives it
    for a in range(1, n, ROWS):
        b = min(a + ROWS, n)
        np.subtract(times[a:b], times[a - 1 : b - 1], out=dt[a:b])
    span = np.maximum(np.ptp(q_cmd, axis=0), 1e-12)
    hold = max(1, int(round(AFTER_REVERSAL_S / float(_median(dt))))) if is_stream else AFTER_REVERSAL_SAMPLES
    rising = np.zeros((n, joints), dtype=bool)
    after = np.zeros((n, joints), dtype=bool)
    fast = np.zeros((n, joints), dtype=bool)
    total = scratch((n,))  # every joint's step over its range, summed joint after joint
    total[:] = 0.0
    for j in range(joints):
        _directions(q_cmd[:, j], 0.005 * span[j], hold, rising[:, j], after[:, j])
        speed = scratch((n,))
        for a in range(0, n, ROWS):
            step = _step(q_cmd[:, j], a)
            np.divide(step, np.maximum(dt[a : a + ROWS], 1e-12), out=speed[a : a + ROWS])
            total[a : a + ROWS] += step / span[j]
        top = _percentile(speed, 67)
        for a in range(0, n, ROWS):
            fast[a : a + ROWS, j] = speed[a : a + ROWS] > top
    others_moving = np.zeros((n, joints), dtype=bool)
    others = scratch((n,))
    for j in range(joints):
        for a in range(0, n, ROWS):
            np.subtract(total[a : a + ROWS], _step(q_cmd[:, j], a) / span[j], out=others[a : a + ROWS])
        middle = _median(others)
        for a in range(0, n, ROWS):
            others_moving[a : a + ROWS, j] = others[a : a + ROWS] > middle
    return _Motion(rising, after, fast, others_moving)


def _directions(
    command: Array, half_width: float, hold: int, rising: NDArray[np.bool_], after: NDArray[np.bool_]
) -> None:
    """Into `rising` and `after`: where the joint's last move (of its play path, which ignores dithering
    below `half_width`) was up, and the `hold` samples from each reversal of that move."""
    n = len(command)
    last_output: float | None = None
    previous, carry = command[0], 0.0  # the path's sample before the chunk, the last nonzero move
    for a in range(0, n, ROWS):
        path = play_grid(command[a : a + ROWS], half_width, last_output)[:, 0]
        moves = np.sign(np.diff(path, prepend=previous if a else path[0]))
        last_move = np.maximum.accumulate(np.where(moves != 0, np.arange(len(moves)), -1))
        carried = np.where(last_move >= 0, moves[np.maximum(last_move, 0)], carry)
        rising[a : a + len(path)] = carried > 0
        before = np.r_[carry, carried[:-1]]
        for start in np.flatnonzero(carried * before < 0) + a:
            after[start : start + hold] = True
        last_output, previous, carry = path[-1], path[-1], carried[-1]


def _step(command: Array, a: int) -> Array:
    """|command[i] − command[i − 1]| for the chunk's samples i from `a` (0 for the first sample)."""
    chunk = command[a : a + ROWS]
    return np.abs(np.diff(chunk, prepend=command[a - 1] if a else chunk[0]))


def _median(values: Array) -> float:
    """`np.median(values)`, sorting a scratch copy in place, not one in memory."""
    copy = scratch(values.shape)
    copy[:] = values
    return float(np.median(copy, overwrite_input=True))


def _percentile(values: Array, q: float) -> float:
    """`np.percentile(values, q)`, sorting a scratch copy in place, not one in memory."""
    copy = scratch(values.shape)
    copy[:] = values
    return float(np.percentile(copy, q, overwrite_input=True))


def _compare(r: Array, inside: NDArray[np.bool_], label: str) -> Regime | None:
    if inside.sum() < 5 or (~inside).sum() < 5:
        return None
    r_in, r_out = scratch_where(r, inside), scratch_where(r, ~inside)  # what `r[inside]` would copy
    return Regime(
        label,
        float(inside.mean()),
        float(np.sqrt(np.square(r_in, out=scratch(r_in.shape)).mean())),
        float(np.sqrt(np.square(r_out, out=scratch(r_out.shape)).mean())),
        float(r_in.mean()),
        float(r_out.mean()),
    )


def _regimes(j: int, r: Array, q_cmd: Array, motion: _Motion) -> list[Regime]:
    name = JOINT_NAMES[j]
    found: list[Regime | None] = []
    for k, other in enumerate(JOINT_NAMES):
        found.append(_compare(r, motion.after_reversal[:, k], f"just after {other} reverses"))
        found.append(_compare(r, motion.rising[:, k], f"while {other} rises (against falls and rests)"))
    found.append(_compare(r, motion.fast[:, j], f"when {name} moves fast (top third of its speeds)"))
    high = q_cmd[:, j] > _percentile(q_cmd[:, j], 67)
    low = q_cmd[:, j] < _percentile(q_cmd[:, j], 33)
    found.append(_compare(r, high, f"when {name} is commanded high (top third of its range)"))
    found.append(_compare(r, low, f"when {name} is commanded low (bottom third of its range)"))
    found.append(_compare(r, motion.others_moving[:, j], "when the other joints move more than usual"))
    notable = [regime for regime in found if regime is not None and regime.strength >= NOTABLE]
    return sorted(notable, key=lambda regime: -regime.strength)[:MAX_REGIMES]
