"""Recalibrate a re-homed arm from a few set-points: keep a physics model's effects, refit what moved.

Re-homing moves where each joint's zero is (`../shared/data/dvrk/README.md`: offsets differ between
set-ups of the same arm), so every joint's offset is refitted freely. The shared recordings show more
moves between set-ups of one arm: the gains (scales, couplings' and hysteresis' k) and the widths of the
cables' play (a set-up's wrist hysteresis is 0.15–0.36 rad wide, another's of the same arm 0.03). A few
set-points cannot pin all of that down, so per joint the refit tries its play widths times each of
`WIDTH_FACTORS` and its gains under a Gaussian prior centred on the old model at each of
`PRIOR_STRENGTHS`, and keeps what the set-points themselves prefer: a candidate later in that order
must lower the leave-one-out error to `LOO_GUARD` of the best before it, so the old widths and gains
stay unless the set-points say otherwise. The model is linear in its offsets, scales and couplings and
nearly so in its hysteresis gains around the old values, so one Gauss-Newton step on finite-difference
derivatives solves each candidate, and leave-one-out errors have the closed form of a ridge regression.
`pegbt bench calibration-refit` measures it on the shared recordings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.calibration.task import task_box
from pegbt.errors import PegbtError
from pegbt.physics import Effect
from pegbt.physics.faults import detect_faults
from pegbt.physics.recording import Recording
from pegbt.psm import JOINT_NAMES

Array = NDArray[np.float64]

# Prior strength on a gain, in units of what the set-points themselves say about it (each derivative
# column scaled to unit norm): 1 weighs the old value as much as all N set-points; inf keeps it.
PRIOR_STRENGTHS = (float("inf"), 10.0, 3.0, 1.0, 0.3, 0.1, 0.03, 0.01)
WIDTH_FACTORS = (1.0, 2.0, 0.5, 4.0, 0.25, 8.0, 0.1)  # a joint's play widths times these, nearest 1 first
LOO_GUARD = 0.95  # a weaker prior must lower the leave-one-out error to this fraction of the stronger's
# Fewest set-points a refit accepts: leave-one-out over a joint with an offset and up to four gains (the
# most any joint has in the models of the shared recordings) needs at least twice as many samples.
MIN_REFIT_SAMPLES = 10
MIN_KNOWN = 5  # set-points with a known memory a joint's gains need; fewer, and only its offset moves
# Share of the task's range of a joint (`task_box`) that the set-points must span before the gains that
# joint drives are refitted: a gain fitted on a corner of the range extrapolates everywhere else (the
# recordings' first 20 set-points hold the wrist within 3 % of its range; refitted there, the gains make
# the model worse than none on the rest of the session).
MIN_SPAN = 0.25
GAINS = {"scale": "value", "coupling": "k", "hysteresis": "k"}
STEP = 1e-4  # finite-difference step of a gain or offset (rad, m or unitless)


@dataclass(frozen=True)
class JointRefit:
    """What a joint's refit moved: its offset, its play widths and its gains under the chosen prior."""

    joint: str
    prior: float  # the chosen strength (inf: gains kept)
    width_factor: float  # the joint's play widths were multiplied by this (1: kept)
    moved: tuple[tuple[str, float, float], ...]  # (parameter, old, new)
    held: str = ""  # why the widths and gains were kept whatever the set-points say, if they were
    narrow: bool = False  # held because the set-points span too little of the range (collect spread ones)

    def to_dict(self) -> dict[str, object]:
        return {
            "joint": self.joint,
            "prior": None if np.isinf(self.prior) else self.prior,
            "width_factor": self.width_factor,
            "moved": [{"parameter": p, "old": a, "new": b} for p, a, b in self.moved],
            "held": self.held,
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
    what = f"{effect.effect} {source}→{effect.joint}" if source else f"{effect.effect} on {effect.joint}"
    return what if name == "value" else f"{what} {name}"


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


def _widened(effects: list[Effect], joint: str, factor: float) -> list[Effect]:
    """`effects` with the play widths of the effects on `joint` multiplied by `factor`."""
    return [
        Effect(e.effect, e.joint, {**e.params, "half_width": float(e.params["half_width"]) * factor})
        if e.joint == joint and "half_width" in e.params
        else e
        for e in effects
    ]


@dataclass(frozen=True)
class _Options:
    rows: NDArray[np.bool_]  # the set-points a joint's leave-one-out counts
    factors: tuple[float, ...]
    strengths: tuple[float, ...]


@dataclass(frozen=True)
class _Candidate:
    loo: float
    prior: float
    width_factor: float
    effects: list[Effect]  # the joint's effects widened and refitted (the other joints' as they were)


def _refit_joint(
    arm: str, old: list[Effect], j: int, q_cmd: Array, q_phy: Array, at: NDArray[np.intp], options: _Options
) -> _Candidate:
    """The candidate the set-points `at` prefer for joint `j`: widths times each factor, gains under each
    prior strength (column 0, the offset, free), compared by leave-one-out error on the `options.rows`."""
    joint = JOINT_NAMES[j]
    best: _Candidate | None = None
    for factor in options.factors:
        shaped = _widened(old, joint, factor)
        predicted = PhysicsModel.from_effects(arm, shaped, "").predict(q_cmd)[at, j]
        parameters = _parameters(shaped, joint)
        columns = []
        for index, name in parameters:
            nudged = _moved(shaped, index, name, float(shaped[index].params[name]) + STEP)
            columns.append(
                (PhysicsModel.from_effects(arm, nudged, "").predict(q_cmd)[at, j] - predicted) / STEP
            )
        design = np.column_stack(columns)[options.rows]
        target = (q_phy[:, j] - predicted)[options.rows]
        norm = np.maximum(np.sqrt((design**2).sum(0)), 1e-12)
        for strength in options.strengths:
            coefficients, loo = _ridge(design / norm, target, strength)
            if best is None or loo < LOO_GUARD * best.loo:
                effects = shaped
                for (index, name), delta in zip(parameters, coefficients / norm):
                    effects = _moved(effects, index, name, float(shaped[index].params[name]) + float(delta))
                best = _Candidate(loo, strength, factor, effects)
    assert best is not None
    return best


def _held(effects: list[Effect], joint: str, spans: Array) -> str:
    """Why `joint`'s widths and gains cannot be refitted from set-points spanning `spans` of the task's
    range per joint (empty if they can): the joint, or a joint driving one of its effects, barely moved."""
    drives = [joint] + [str(e.params["source"]) for e in effects if e.joint == joint and "source" in e.params]
    narrow = sorted({d for d in drives if spans[JOINT_NAMES.index(d)] < MIN_SPAN})
    if not narrow:
        return ""
    spanned = ", ".join(f"{d} {100 * spans[JOINT_NAMES.index(d)]:.1f} %" for d in narrow)
    return f"the set-points span {spanned} of the task's range, under the {100 * MIN_SPAN:g} % a refit of gains needs"


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
    """`model` refitted on the first `samples` set-points of `recording` (see `refit_at`)."""
    if not MIN_REFIT_SAMPLES <= samples <= recording.n:
        raise PegbtError(
            f"--samples must be {MIN_REFIT_SAMPLES}..{recording.n}, got {samples}", field="--samples"
        )
    return refit_at(model, recording, np.arange(samples), gains)


def refit_at(
    model: CalibrationModel, recording: Recording, at: NDArray[np.intp], gains: bool = True
) -> tuple[PhysicsModel, list[JointRefit]]:
    """`model` (a physics model) refitted on the set-points `at` (increasing indices) of `recording`,
    measurement faults among them left out: offsets free; play widths and gains as the set-points prefer
    (both kept, without `gains`); and what moved. The model's memory runs over every command up to the
    last of them, as it would have on the arm."""
    if not isinstance(model, PhysicsModel):
        raise PegbtError(f"refit keeps a physics model's shape; this is a {model.kind} model", field="MODEL")
    history = recording.slice(0, int(at[-1]) + 1)
    faulty = ~detect_faults(history.q_cmd, history.q_phy, history.limits).kept
    at = at[~faulty[at]]
    if len(at) < MIN_REFIT_SAMPLES:
        raise PegbtError(
            f"only {len(at)} of the set-points are not measurement faults; a refit needs {MIN_REFIT_SAMPLES}",
            field="--samples",
        )
    q_cmd, q_phy = history.q_cmd, history.q_phy[at]
    old = _complete(model.effects)
    known = known_memory(model, q_cmd)[at]
    lower, upper = task_box(model.arm)
    spans = np.ptp(q_cmd[at], axis=0) / (upper - lower)
    effects = list(old)
    report = []
    for j, joint in enumerate(JOINT_NAMES):
        enough = bool(known[:, j].sum() >= MIN_KNOWN)
        held = _held(old, joint, spans) if gains else "offsets only, as asked"
        narrow = gains and bool(held)
        if not enough and not held:
            held = f"fewer than {MIN_KNOWN} set-points after its play's memory is known"
        options = _Options(
            known[:, j] if enough else np.ones(len(at), dtype=bool),
            WIDTH_FACTORS
            if not held and any(e.joint == joint and "half_width" in e.params for e in old)
            else (1.0,),
            (np.inf,) if held else PRIOR_STRENGTHS,
        )
        best = _refit_joint(model.arm, old, j, q_cmd, q_phy, at, options)
        moved = []
        for index, (before, after) in enumerate(zip(old, best.effects)):
            if before.joint != joint:
                continue
            effects[index] = after
            for name, value in before.params.items():
                if not isinstance(value, str) and abs(float(after.params[name]) - value) > 1e-12:
                    moved.append((_label(before, name), value, float(after.params[name])))
        report.append(JointRefit(joint, best.prior, best.width_factor, tuple(moved), held, narrow))
    effects = [
        e for e in effects if not (e.effect in ("offset", "scale") and e.params["value"] == e.kind.neutral)
    ]
    source = model.metadata.training.get("effects_from", "") if model.metadata else ""
    refitted = PhysicsModel.from_effects(model.arm, effects, f"{source} refitted".strip())
    assert refitted.metadata is not None
    training = dict(refitted.metadata.training)
    training.update(
        {"refit_on": str(recording.path), "refit_samples": len(at), "refit": [r.to_dict() for r in report]}
    )
    refitted.metadata = replace(refitted.metadata, training=training)
    return refitted, report
