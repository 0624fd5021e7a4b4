"""Recalibrate a re-homed arm from a few set-points: keep a physics model's shape, refit what moved.

Re-homing moves where each joint's zero is (`../shared/data/dvrk/README.md`: offsets differ between
set-ups of the same arm), so every joint's offset is refitted freely. The shared recordings show more
moves between set-ups of one arm: refitting only offsets on the whole first 70 % of the new session
recovers little of what a model trained there gains, while refitting the gains too (scales, couplings'
and hysteresis' k, the widths kept) recovers most of it (`pegbt bench calibration-refit`). A few
set-points cannot pin down every gain, so the gains are refitted under a Gaussian prior centred on the
old model, per joint, with the prior's strength chosen by the set-points themselves: the weakest prior
in `PRIOR_STRENGTHS` whose leave-one-out error beats the next stronger one by `LOO_GUARD` (the strongest
keeps the gains and moves only the offset). The model is linear in its offsets, scales and couplings and
nearly so in its hysteresis gains around the old values, so one Gauss-Newton step on finite-difference
derivatives solves it, and leave-one-out errors have the closed form of a ridge regression.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.errors import PegbtError
from pegbt.physics import Effect
from pegbt.physics.faults import detect_faults
from pegbt.physics.recording import Recording
from pegbt.psm import JOINT_NAMES

Array = NDArray[np.float64]

# Prior strength on a gain, in units of what the set-points themselves say about it (each derivative
# column scaled to unit norm): 1 weighs the old value as much as all N set-points; inf keeps it.
PRIOR_STRENGTHS = (float("inf"), 10.0, 3.0, 1.0, 0.3)
LOO_GUARD = 0.95  # a weaker prior must lower the leave-one-out error to this fraction of the stronger's
# Fewest set-points a refit accepts: leave-one-out over a joint with an offset and up to four gains (the
# most any joint has in the models of the shared recordings) needs at least twice as many samples.
MIN_REFIT_SAMPLES = 10
MIN_KNOWN = 5  # set-points with a known memory a joint's gains need; fewer, and only its offset moves
GAINS = {"scale": "value", "coupling": "k", "hysteresis": "k"}
STEP = 1e-4  # finite-difference step of a gain or offset (rad, m or unitless)


@dataclass(frozen=True)
class JointRefit:
    """What a joint's refit moved: its offset, and its gains under the chosen prior strength."""

    joint: str
    prior: float  # the chosen strength (inf: gains kept)
    moved: tuple[tuple[str, float, float], ...]  # (parameter, old, new)

    def to_dict(self) -> dict[str, object]:
        return {
            "joint": self.joint,
            "prior": None if np.isinf(self.prior) else self.prior,
            "moved": [{"parameter": p, "old": a, "new": b} for p, a, b in self.moved],
        }


def _complete(effects: Sequence[Effect]) -> list[Effect]:
    """The effects with an offset and a scale on every joint (neutral where the model has none), so that
    what re-homing moves always has a parameter to move."""
    have = {(e.effect, e.joint) for e in effects}
    extra = [Effect("offset", j, {"value": 0.0}) for j in JOINT_NAMES if ("offset", j) not in have]
    extra += [Effect("scale", j, {"value": 1.0}) for j in JOINT_NAMES if ("scale", j) not in have]
    return list(effects) + extra


def _parameters(effects: list[Effect], joint: str) -> list[tuple[int, str]]:
    """(effect index, parameter name) of the joint's offset first, then its gains."""
    offset = [(i, "value") for i, e in enumerate(effects) if e.joint == joint and e.effect == "offset"]
    gains = [(i, GAINS[e.effect]) for i, e in enumerate(effects) if e.joint == joint and e.effect in GAINS]
    return offset + gains


def _moved(effects: list[Effect], index: int, name: str, value: float) -> list[Effect]:
    effect = effects[index]
    changed = list(effects)
    changed[index] = Effect(effect.effect, effect.joint, {**effect.params, name: value})
    return changed


def _label(effect: Effect, name: str) -> str:
    source = effect.params.get("source")
    return (
        f"{effect.effect} {source}→{effect.joint} {name}" if source else f"{effect.effect} on {effect.joint}"
    )


def _ridge(design: Array, target: Array, strength: float) -> tuple[Array, float]:
    """(coefficients, leave-one-out sum of squares) of a ridge fit whose column 0 is free and the rest
    held toward 0 with `strength` (inf: left out); leave-one-out in closed form through the hat matrix."""
    used = 1 if np.isinf(strength) else design.shape[1]
    x = design[:, :used]
    penalty = np.r_[0.0, np.full(used - 1, strength)]
    system = x.T @ x + np.diag(penalty) + 1e-9 * np.eye(used)
    hat = x @ np.linalg.solve(system, x.T)
    residual = (target - hat @ target) / np.maximum(1.0 - np.diag(hat), 1e-9)
    coefficients = np.zeros(design.shape[1])
    coefficients[:used] = np.linalg.solve(system, x.T @ target)
    return coefficients, float(residual @ residual)


def _refit_joint(design: Array, target: Array, strengths: tuple[float, ...]) -> tuple[float, Array]:
    """(chosen prior strength, parameter changes) for one joint; column 0 is its offset (no prior)."""
    norm = np.maximum(np.sqrt((design**2).sum(0)), 1e-12)
    best: tuple[float, Array, float] | None = None
    for strength in strengths:
        coefficients, loo = _ridge(design / norm, target, strength)
        if best is None or loo < LOO_GUARD * best[2]:
            best = (strength, coefficients, loo)
    assert best is not None
    return best[0], best[1] / norm


def known_memory(model: PhysicsModel, q_cmd: Array) -> NDArray[np.bool_]:
    """(N, 6): whether each joint's memory at each set-point is set by the commands so far. A play of half
    width h forgets where it started once its drive has spanned 2h; before that it holds the state the arm
    had before the session, which no model knows, and a refit that fitted it would bend the gains."""
    arm = model.settled
    known = np.ones(q_cmd.shape, dtype=bool)
    drives = q_cmd @ arm.drive_rows.T + arm.drive_offsets  # (N, H): every hysteresis's drive
    targets = q_cmd @ arm.matrix.T + arm.physics.offset  # backlash acts on the joint's static target
    plays = [(int(np.argmax(arm.into[:, h])), drives[:, h], arm.play[h]) for h in range(len(arm.play))]
    plays += [
        (j, targets[:, j], float(e.params["half_width"]))
        for j, _, e in arm.transforms
        if "half_width" in e.params
    ]
    for j, drive, half_width in plays:
        span = np.maximum.accumulate(drive) - np.minimum.accumulate(drive)
        known[:, j] &= span >= 2 * half_width
    return known


def refit(
    model: CalibrationModel, recording: Recording, samples: int, gains: bool = True
) -> tuple[PhysicsModel, list[JointRefit]]:
    """`model` (a physics model) refitted on the first `samples` set-points of `recording` (measurement
    faults among them left out): offsets free, gains toward the old values (kept, without `gains`),
    widths kept; and what moved."""
    if not isinstance(model, PhysicsModel):
        raise PegbtError(f"refit keeps a physics model's shape; this is a {model.kind} model", field="MODEL")
    if not MIN_REFIT_SAMPLES <= samples <= recording.n:
        raise PegbtError(
            f"--samples must be {MIN_REFIT_SAMPLES}..{recording.n}, got {samples}", field="--samples"
        )
    head = recording.slice(0, samples)
    kept = detect_faults(head.q_cmd, head.q_phy).kept
    q_cmd, q_phy = head.q_cmd[kept], head.q_phy[kept]
    if len(q_cmd) < MIN_REFIT_SAMPLES:
        raise PegbtError(
            f"only {len(q_cmd)} of the first {samples} set-points are not measurement faults; a refit needs "
            f"{MIN_REFIT_SAMPLES}",
            field="--samples",
        )
    old = _complete(model.effects)
    predicted = PhysicsModel.from_effects(model.arm, old, "").predict(q_cmd)
    effects = list(old)
    known = known_memory(model, q_cmd)
    report = []
    for j, joint in enumerate(JOINT_NAMES):
        rows = known[:, j] if known[:, j].sum() >= MIN_KNOWN else np.ones(len(q_cmd), dtype=bool)
        parameters = _parameters(old, joint)
        columns = []
        for index, name in parameters:
            nudged = _moved(old, index, name, float(old[index].params[name]) + STEP)
            columns.append(
                (PhysicsModel.from_effects(model.arm, nudged, "").predict(q_cmd)[:, j] - predicted[:, j])
                / STEP
            )
        strength, change = _refit_joint(
            np.column_stack(columns)[rows],
            (q_phy[:, j] - predicted[:, j])[rows],
            PRIOR_STRENGTHS if gains and rows.sum() >= MIN_KNOWN else (np.inf,),
        )
        moved = []
        for (index, name), delta in zip(parameters, change):
            before = float(old[index].params[name])
            effects = _moved(effects, index, name, before + float(delta))
            if abs(delta) > 1e-12:
                moved.append((_label(old[index], name), before, before + float(delta)))
        report.append(JointRefit(joint, strength, tuple(moved)))
    effects = [
        e for e in effects if not (e.effect in ("offset", "scale") and e.params["value"] == e.kind.neutral)
    ]
    source = model.metadata.training.get("effects_from", "") if model.metadata else ""
    refitted = PhysicsModel.from_effects(model.arm, effects, f"{source} refitted".strip())
    assert refitted.metadata is not None
    training = dict(refitted.metadata.training)
    training.update(
        {
            "refit_on": str(recording.path),
            "refit_samples": int(kept.sum()),
            "refit": [r.to_dict() for r in report],
        }
    )
    refitted.metadata = replace(refitted.metadata, training=training)
    return refitted, report
