"""Recalibrate a re-homed arm from a few set-points: keep a physics model's shape, refit its offsets.

Re-homing an arm moves where each joint's zero is, not how its cables couple, play or stretch
(`../shared/data/dvrk/README.md`: offsets differ between set-ups of the same arm). So a model from one
set-up keeps its couplings, play and hysteresis, and only its offsets are refitted from the first set-points
of the new session: an offset adds to a joint's static target, and every later stage (hysteresis on the
joint's own drive, backlash) is shift-invariant, so the settled output moves by exactly the change in
offset, which is the mean of what the model misses over those set-points.
"""

from __future__ import annotations

from dataclasses import replace

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.errors import PegbtError
from pegbt.physics import Effect
from pegbt.physics.faults import detect_faults
from pegbt.physics.recording import Recording
from pegbt.psm import JOINT_NAMES


def refit_offsets(model: CalibrationModel, recording: Recording, samples: int) -> PhysicsModel:
    """`model` (a physics model) with its offsets refitted on the first `samples` set-points of `recording`
    (measurement faults among them left out)."""
    if not isinstance(model, PhysicsModel):
        raise PegbtError(f"refit keeps a physics model's shape; this is a {model.kind} model", field="MODEL")
    if not 1 <= samples <= recording.n:
        raise PegbtError(f"--samples must be 1..{recording.n}, got {samples}", field="--samples")
    head = recording.slice(0, samples)
    kept = detect_faults(head.q_cmd, head.q_phy).kept
    shift = (head.q_phy - model.predict(head.q_cmd))[kept].mean(axis=0)
    offsets = {e.joint: e for e in model.effects if e.effect == "offset"}
    effects = [e for e in model.effects if e.effect != "offset"]
    for j, joint in enumerate(JOINT_NAMES):
        value = float(offsets[joint].params["value"] if joint in offsets else 0.0) + float(shift[j])
        effects.append(Effect("offset", joint, {"value": value}))
    source = model.metadata.training.get("effects_from", "") if model.metadata else ""
    refitted = PhysicsModel.from_effects(model.arm, effects, f"{source} refitted".strip())
    assert refitted.metadata is not None
    training = dict(refitted.metadata.training)
    training.update({"refit_on": str(recording.path), "refit_samples": int(kept.sum())})
    refitted.metadata = replace(refitted.metadata, training=training)
    return refitted
