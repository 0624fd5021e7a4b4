"""How well a model predicts the physical joints it was not trained on, in joint space and at the tool tip.

The model sees every command of the recording (commands are known, so the history before the test
part is legitimate), and is scored on samples [start, end) against the measured joints. The same
figures for the raw commands (no model: q_phy ≈ q_cmd) are the uncompensated baseline. Tip error is the
distance between the tool tips that forward kinematics puts at the measured and the predicted joints.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.calibration.base import CalibrationModel, check_arm
from pegbt.errors import PegbtError
from pegbt.motion.kinematics import tip_position
from pegbt.physics.recording import Recording
from pegbt.psm import JOINT_NAMES


def joint_rmse(predicted: NDArray[np.float64], measured: NDArray[np.float64]) -> dict[str, float]:
    """Per-joint RMSE (rad; m for q3), by joint name: the scores `calibrate eval --json` reports per joint."""
    rmse = np.sqrt(np.mean((predicted - measured) ** 2, axis=0))
    return {name: float(value) for name, value in zip(JOINT_NAMES, rmse)}


def tip_error_mm(predicted: NDArray[np.float64], measured: NDArray[np.float64]) -> NDArray[np.float64]:
    """Tool-tip distance (mm) between the two joint sets of each row, through forward kinematics.

    Joint errors in rad and m do not add up; the tip is where the task succeeds or fails, and it is the
    figure the reference paper reports."""
    return 1000.0 * np.linalg.norm(tip_position(predicted) - tip_position(measured), axis=-1)


def evaluate(
    model: CalibrationModel, recording: Recording, start: int = 0, kept: NDArray[np.bool_] | None = None
) -> dict[str, Any]:
    """Held-out scores of `model` on samples start.. of `recording` (the `--json` form of `calibrate eval`);
    with `kept`, only on those samples (measurement faults left out), the model's memory running over all."""
    check_arm(recording, model.arm, f"the {model.kind} model")
    if not 0 <= start < len(recording):
        raise PegbtError(f"no samples to score from sample {start} of {len(recording)}", file=recording.path)
    scored = np.arange(start, len(recording))
    if kept is not None:
        scored = scored[kept[start:]]
        if not scored.size:
            raise PegbtError(
                f"every sample from sample {start} is a measurement fault: none to score", file=recording.path
            )
    predicted = model.predict(recording.q_cmd)[scored]
    measured, commanded = recording.q_phy[scored], recording.q_cmd[scored]
    tip, tip_raw = tip_error_mm(predicted, measured), tip_error_mm(commanded, measured)
    return {
        "model": model.kind,
        "arm": model.arm,
        "recording": recording.path.name,
        "samples": len(measured),
        "first_sample": start,
        "joint_rmse": joint_rmse(predicted, measured),
        "joint_rmse_uncompensated": joint_rmse(commanded, measured),
        "tip_err_mm_mean": float(tip.mean()),
        "tip_err_mm_mean_uncompensated": float(tip_raw.mean()),
        "tip_err_mm_median": float(np.median(tip)),
        "tip_err_mm_max": float(tip.max()),
    }
