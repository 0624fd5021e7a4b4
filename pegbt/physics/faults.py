"""Measurement faults: samples of a recording that no arm could have produced.

A fiducial tracker fails in two ways (`../shared/data/dvrk/README.md`, "Clean, unlike raw recordings"):
it loses a sphere for a sample, and every joint jumps at once, even q1–q3 by tenths of a radian; or it
loses the tool for minutes, and the reading leaves the command altogether. Neither is physics, and both
must stay out of any fit. A sample is a fault when, on at least `MIN_JOINTS` joints at once, its error
(measured − commanded) departs by more than `LIMIT` times the joint's typical error (its robust spread
over the whole recording) from its neighbours (a glitch among good samples) or from where the joint
usually sits (a window of samples far from it). Robust: medians and median absolute deviations, so the
faults themselves do not widen the yardstick. Runs of faults become windows.

A sample is also a fault, on one joint alone, where no arm could be (`unreachable`): beyond the robot's own
joint limits by more than a real joint passes them, or, on q1–q3, farther from its command than the dVRK's
controller lets an arm lag before it stops it. A tracker that loses the tool reads the insertion as 0 m
while it was commanded to 0.15 m: the arm was not there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

from pegbt.motion.robot_config import DVRK_LIMITS, RobotLimits
from pegbt.scratch import ROWS, scratch

Array = NDArray[np.float64]

# How far physical joints may lie beyond the robot's limits: rad for rotary joints, m for insertion. A real
# wrist does: the four dVRK recordings' physical joints differ from their commands by up to 0.45 rad (q6).
PHYSICAL_TOLERANCE = np.array([0.5, 0.5, 0.01, 0.5, 0.5, 0.5])
# The dVRK's tracking-error limit of the first three actuators, which are q1–q3 (share/pid/
# sawControllersPID-PSM.json, "p_measured_setpoint_tolerance"; mtsPID.cpp stops the arm beyond it).
TRACKING_TOLERANCE = np.array([0.5, 0.5, 0.05])

LIMIT = 8.0  # robust deviations (MAD × 1.4826) beyond which a joint's error is not its own
MIN_JOINTS = 2  # joints that must depart at once: a tracker fault corrupts the whole pose
NEIGHBOURS = 9  # samples in the running median a glitch is compared with
WINDOW_GAP = 5  # faults this close together belong to one window
MIN_WINDOW = 10  # a run of at least this many faults is lost tracking, not a glitch


@dataclass(frozen=True)
class MeasurementFaults:
    """Which samples are faults, as a mask, and their windows (first, last sample index inclusive)."""

    mask: NDArray[np.bool_]
    windows: tuple[tuple[int, int], ...]  # runs of at least MIN_WINDOW faults: tracking lost
    glitches: int  # isolated faulty samples outside those windows
    unreachable: int = 0  # of all faults, the samples where no arm could be (`unreachable`)

    @property
    def count(self) -> int:
        return int(self.mask.sum())

    @property
    def kept(self) -> NDArray[np.bool_]:
        return ~self.mask

    def sentence(self, times: Array, unit: str = "s") -> str:
        """What happened, for a person: "the tracker lost the tool after 812 s; 240 samples excluded"."""
        if not self.count:
            return "no measurement faults"
        parts = [
            f"the tracker lost the tool from {times[a]:.4g} to {times[b]:.4g} {unit} ({b - a + 1} samples)"
            for a, b in self.windows
        ]
        if self.glitches:
            parts.append(
                f"{self.glitches} isolated samples jumped on several joints at once (tracker glitches)"
            )
        if self.unreachable:
            parts.append(
                f"{self.unreachable} samples lie where no arm could be (beyond the robot's joint limits, or "
                "farther from the command than its controller allows)"
            )
        return "; ".join(parts) + f"; {self.count} samples excluded"

    def to_dict(self, times: Array) -> dict[str, object]:
        return {
            "samples_excluded": self.count,
            "glitches": self.glitches,
            "unreachable": self.unreachable,
            "windows": [[float(times[a]), float(times[b]), b - a + 1] for a, b in self.windows],
            "text": self.sentence(times),
        }


@dataclass(frozen=True)
class Errors:
    """Measured − commanded joints (N, 6) in scratch (`pegbt.scratch`), with each joint's centre (median)
    and typical error (1.4826 × its median absolute deviation): the yardstick of the whole recording, found
    a column at a time, so a long recording's error is never the process's own memory."""

    values: Array
    centre: Array
    spread: Array

    @classmethod
    def of(cls, q_cmd: Array, q_phy: Array) -> Errors:
        error = scratch(q_cmd.shape)
        for a in range(0, len(error), ROWS):
            np.subtract(q_phy[a : a + ROWS], q_cmd[a : a + ROWS], out=error[a : a + ROWS])
        column = scratch((len(error),))
        centre, spread = np.empty(error.shape[1]), np.empty(error.shape[1])
        for j in range(error.shape[1]):
            column[:] = error[:, j]
            centre[j] = np.median(column, overwrite_input=True)  # sorts the copy in place, not a new one
            np.abs(np.subtract(error[:, j], centre[j], out=column), out=column)
            spread[j] = 1.4826 * np.median(column, overwrite_input=True)
        return cls(error, centre, np.maximum(spread, 1e-9))

    def departure(self, a: int, b: int) -> Array:
        """(b − a, 6): how many robust deviations rows [a, b) lie from where their joints usually sit."""
        with np.errstate(over="ignore"):  # a reading of 1e308 departs infinitely far: so it does
            return np.abs(self.values[a:b] - self.centre) / self.spread

    def local(self, a: int, b: int) -> Array:
        """(b − a, 6): how many robust deviations rows [a, b) lie from their running median (`NEIGHBOURS`
        samples, the ends repeated), from the rows around them: the same as over the whole recording."""
        halo = NEIGHBOURS // 2
        lo, hi = max(a - halo, 0), min(b + halo, len(self.values))
        around = self.values[lo:hi]
        median = median_filter(around, size=(NEIGHBOURS, 1), mode="nearest")[a - lo : b - lo]
        with np.errstate(over="ignore"):
            return np.abs(around[a - lo : b - lo] - median) / self.spread


def outlying(errors: Errors, joint: int) -> NDArray[np.bool_]:
    """(N,): where `joint`'s error lies more than `LIMIT` robust deviations from where it usually sits."""
    n = len(errors.values)
    return np.concatenate(
        [errors.departure(a, a + ROWS)[:, joint] > LIMIT for a in range(0, n, ROWS)] or [np.zeros(0, bool)]
    )


def unreachable(q_cmd: Array, q_phy: Array, limits: RobotLimits = DVRK_LIMITS) -> NDArray[np.bool_]:
    """(N, 6): where a physical joint is beyond `limits` by more than `PHYSICAL_TOLERANCE`, or (q1–q3)
    farther from its command than `TRACKING_TOLERANCE`."""
    q_phy = np.asarray(q_phy, float)
    beyond = (q_phy < limits.lower - PHYSICAL_TOLERANCE) | (q_phy > limits.upper + PHYSICAL_TOLERANCE)
    lag = np.abs(q_phy[:, :3] - np.asarray(q_cmd, float)[:, :3]) > TRACKING_TOLERANCE
    beyond[:, :3] |= lag
    return beyond


def detect_faults(q_cmd: Array, q_phy: Array, limits: RobotLimits = DVRK_LIMITS) -> MeasurementFaults:
    """The samples of a recording no arm could produce (see the module docstring); `limits` are the robot's.
    Found `ROWS` samples at a time: what it holds beyond its scratch is a byte a sample, the mask."""
    n = len(q_cmd)
    impossible = np.empty(n, dtype=bool)
    for a in range(0, n, ROWS):
        impossible[a : a + ROWS] = np.any(
            unreachable(q_cmd[a : a + ROWS], q_phy[a : a + ROWS], limits), axis=1
        )
    if n < NEIGHBOURS:
        return MeasurementFaults(impossible, (), int(impossible.sum()), int(impossible.sum()))
    errors = Errors.of(q_cmd, q_phy)
    mask = impossible.copy()
    for a in range(0, n, ROWS):
        b = min(a + ROWS, n)
        departs = np.maximum(errors.local(a, b), errors.departure(a, b)) > LIMIT
        mask[a:b] |= departs.sum(axis=1) >= MIN_JOINTS
    windows = []
    glitches = 0
    index = np.flatnonzero(mask)
    if index.size:
        breaks = np.flatnonzero(np.diff(index) > WINDOW_GAP)
        for run in np.split(index, breaks + 1):
            a, b = int(run[0]), int(run[-1])
            if len(run) >= MIN_WINDOW:
                mask[a : b + 1] = True
                windows.append((a, b))
            else:
                glitches += len(run)
    return MeasurementFaults(mask, tuple(windows), glitches, int(impossible.sum()))
