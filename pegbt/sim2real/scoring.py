"""Score a diagnosis against a synthetic recording's ground truth (benchmarks and tests)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pegbt.physics import Effect
from pegbt.psm import JOINT_NAMES
from pegbt.sim2real.diagnose import Diagnosis, crossval_predict, structure_from_effects
from pegbt.sim2real.fit import fit_joint
from pegbt.sim2real.synth import Synthetic, effect_label


def effect_key(effect: Effect) -> tuple[str, str, str]:
    return (effect.effect, effect.joint, str(effect.params.get("source", "")))


def relative_errors(truth: Effect, named: Effect) -> list[float]:
    """Relative error of each numeric parameter, relative to its departure from the value that changes
    nothing (a scale's from 1)."""
    errors = []
    for name, value in truth.params.items():
        if name == "source":
            continue
        reference = abs(value - truth.kind.neutral)
        errors.append(abs(named.params[name] - value) / max(reference, 1e-12))
    return errors


@dataclass(frozen=True)
class Score:
    found: dict[str, bool]  # by true effect's label: named with the right kind, joint (and source)
    false_names: int  # named effects absent from the truth
    named: int
    param_errors: list[float]
    oracle_gain_fraction: float | None


def score(synthetic: Synthetic, diagnosis: Diagnosis) -> Score:
    """How well `diagnosis` recovered the effects concealed in `synthetic`: which it named (cable effects,
    and zero offsets of q1–q3 reported as geometry), which it named that are not there, how far off their
    parameters are, and how much of the oracle's held-out gain it got.

    Only synthetic recordings have a truth to score against; `pegbt bench sim2real` sums these per family."""
    named = {effect_key(e.effect): e.effect for e in (*diagnosis.effects, *diagnosis.zero_offsets)}
    truth = {effect_key(e): e for e in synthetic.effects}
    found = {effect_label(effect): key in named for key, effect in truth.items()}
    errors = [
        err for key, effect in truth.items() if key in named for err in relative_errors(effect, named[key])
    ]
    false_names = sum(1 for key in named if key not in truth)
    return Score(found, false_names, len(named), errors, _oracle_fraction(synthetic, diagnosis))


def _oracle_fraction(synthetic: Synthetic, diagnosis: Diagnosis) -> float | None:
    """Held-out gain of the diagnosis over that of the true structure refitted on the same data."""
    if not synthetic.effects:
        return None
    recording = diagnosis.recording
    t = recording.t if diagnosis.sampling.is_stream else None
    residual = diagnosis.residual_before
    drivers = diagnosis.base.static_map(recording.q_cmd)
    oracle = [
        fit_joint(s, recording.q_cmd, t, residual[:, s.joint], drivers[:, s.joint])
        for s in structure_from_effects(synthetic.effects)
    ]
    predicted = crossval_predict(oracle, diagnosis.base, recording, t, residual, diagnosis.fold_ranges)
    before = (residual**2).mean(0)
    after_tool = (diagnosis.residual_after**2).mean(0)
    after_oracle = ((recording.q_phy - predicted) ** 2).mean(0)
    joints = sorted({JOINT_NAMES.index(e.joint) for e in synthetic.effects})
    gain_tool = sum((before[j] - after_tool[j]) / before[j] for j in joints)
    gain_oracle = sum((before[j] - after_oracle[j]) / before[j] for j in joints)
    return float(gain_tool / gain_oracle) if gain_oracle > 0 else None


def detection_threshold(levels: list[float], rates: list[float], target: float = 0.8) -> float:
    """Lowest SNR at which the naming rate reaches `target` (log-linear between levels; inf if never)."""
    for i, (level, rate) in enumerate(zip(levels, rates)):
        if rate >= target:
            if i == 0:
                return level
            lo, hi = rates[i - 1], rate
            w = (target - lo) / (hi - lo) if hi > lo else 1.0
            return float(np.exp(np.log(levels[i - 1]) + w * (np.log(level) - np.log(levels[i - 1]))))
    return float("inf")
