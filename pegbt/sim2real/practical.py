"""Practical significance: of the effects the tests found, which matter, and how much each explains.

A test says an effect is there; it does not say a person should care. After selection, each joint's
chosen effects (its offset among them) enter again one at a time from no model at all, greedily, each
step adding the one whose held-out gain is largest. An effect's share is that gain over the joint's
held-out error before any effect, so the shares add up to what the model explains, and a joint whose
error is mostly bias gets its offset first. An effect is *below resolution*, listed and never named (the
model still predicts with it: the tests chose it), when
its largest contribution over the recording is smaller than the joint's measurement resolution, or when
it lowers the joint's held-out error by less than `PRACTICAL_GAIN` of it: of the joint's whole error when
the measurement's resolution is known (a real instrument: what a person can use), else of the error left
when it enters (a synthetic recording without one: a small effect under a large one still counts).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pegbt.physics.effects import joint_unit
from pegbt.psm import JOINT_NAMES
from pegbt.sim2real.crossval import BlockedGrams
from pegbt.sim2real.select import Chosen, JointSelection

Array = NDArray[np.float64]

PRACTICAL_GAIN = 0.02
# The paper's fiducial tracker's per-joint resolution (rad, rad, m, rad, rad, rad; `../shared/data/dvrk/README.md`,
# "Measurement resolution"): a dVRK arm's recording that states none is diagnosed at it.
PAPER_RESOLUTION = (0.01, 0.01, 0.0005, 0.01, 0.01, 0.01)


@dataclass(frozen=True)
class BelowResolution:
    """A selected effect too small to name: what it was, how large, and why it is not named."""

    joint: int
    label: str
    size: float  # its largest contribution over the recording, in the joint's units
    gain: float  # the held-out gain it would have added, as a fraction of the error left
    reason: str

    def to_dict(self) -> dict[str, object]:
        return {
            "joint": JOINT_NAMES[self.joint],
            "effect": self.label,
            "largest_contribution": self.size,
            "heldout_gain": self.gain,
            "reason": self.reason,
        }


def _label(chosen: Chosen) -> str:
    return (
        "offset on " + JOINT_NAMES[chosen.candidate.joint] if chosen.column == 0 else chosen.candidate.label
    )


def _size(grams: BlockedGrams, joint: int, item: Chosen, free: list[int], fixed: list[int]) -> float:
    """The item's largest contribution in the in-sample fit of the model it enters: an offset's value,
    half the peak-to-peak of any other effect's term."""
    if item.fixed:
        return 0.5 * float(np.ptp(grams.column_values([item.column])))
    beta = grams.fit(joint, np.array(free), np.array(fixed, dtype=np.int64))[free.index(item.column)]
    if item.column == 0:
        return abs(float(beta))
    return 0.5 * abs(float(beta)) * float(np.ptp(grams.column_values([item.column])))


def settle_joint(
    grams: BlockedGrams, selection: JointSelection, resolution: float | None
) -> tuple[JointSelection, list[BelowResolution]]:
    """The selection keeping only what matters, in greedy order with honest shares, and what it drops."""
    pool = ([selection.offset] if selection.offset else []) + list(selection.chosen)
    joint = selection.joint
    unit = joint_unit(JOINT_NAMES[joint])
    below: list[BelowResolution] = []
    before = float(grams.cv_sse(joint, np.array([], dtype=np.int64)).sum())
    free: list[int] = []
    fixed: list[int] = []
    current = before
    kept: list[Chosen] = []
    while pool:
        trials = [
            (free, fixed + [item.column]) if item.fixed else (free + [item.column], fixed) for item in pool
        ]
        scores = [
            float(grams.cv_sse(joint, np.array(f), np.array(x, dtype=np.int64)).sum()) for f, x in trials
        ]
        best = int(np.argmin(scores))
        item = pool.pop(best)
        size = _size(grams, joint, item, *trials[best])
        reference = before if resolution is not None else current
        gain = (current - scores[best]) / max(reference, 1e-300)
        if resolution is not None and size < resolution:
            reason = (
                f"its largest contribution {size:.2g} {unit} is below the resolution {resolution:.2g} {unit}"
            )
            below.append(BelowResolution(joint, _label(item), size, max(gain, 0.0), reason))
            continue
        if gain < PRACTICAL_GAIN:
            of = "of the joint's error" if resolution is not None else "of the error left"
            reason = f"it lowers the held-out error by less than {100 * PRACTICAL_GAIN:.0f} % {of}"
            for other in [item, *pool]:
                below.append(BelowResolution(joint, _label(other), size, max(gain, 0.0), reason))
            break
        kept.append(replace(item, explains=(current - scores[best]) / max(before, 1e-300)))
        free, fixed = trials[best]
        current = scores[best]
    offset = next((item for item in kept if item.column == 0), None)
    chosen = [item for item in kept if item.column != 0]
    return replace(selection, chosen=chosen, offset=offset), below
