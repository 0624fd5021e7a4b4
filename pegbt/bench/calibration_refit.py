"""`pegbt bench calibration-refit`: recalibrating a re-homed arm from 20 set-points.

For each pair of set-ups of the same arm in the dVRK recordings (both ways), the tip error (mean, mm,
through forward kinematics) of the physics model's prediction on the last 30 % of the new session: no
compensation, the other set-up's model (trained on all of it), that model refitted on `SAMPLES`
set-points of the new session (`pegbt.calibration.refit`), and a model trained on the new session's
first 70 %. `recovered` is a refit's share of the trained model's gain over no compensation (goal: at
least 0.8).

Which 20 set-points: the recordings' own first 20 lie along the start of one slow teleoperated path (the
wrist within 3 % of its range), which no refit collection looks like; `pegbt calibrate collect --refit`
walks a random path over the task's joints instead. So the refit is scored on `DRAWS` draws of
`SAMPLES` set-points at random from the new session's first 70 %, each with the recorded history of
commands before it (median and worst draw), beside the recording's first 20 and, on the same draws,
the offsets alone refitted (the model's widths and gains kept). `refit_first_own_shape` bounds what any
refit that keeps a shape can take from the recording's first 20: the new session's own trained model,
its offsets refitted on them.
"""

from __future__ import annotations

import numpy as np

from pegbt.bench import Figures
from pegbt.calibration.base import CalibrationModel, new_model
from pegbt.calibration.evaluation import tip_error_mm
from pegbt.calibration.refit import refit, refit_at
from pegbt.physics.recording import Recording, dvrk_data_dir, load_recording

SAME_ARM = (("grey1_PSM1", "new1_PSM1"), ("grey2_PSM2", "new2_PSM2"))
SAMPLES = 20
DRAWS = 10
TRAIN_FRACTION = 0.7


def _recording(name: str) -> Recording:
    return load_recording(dvrk_data_dir(required=True) / f"random_smooth_{name}")


def _tip_mm(model: CalibrationModel, session: Recording, start: int) -> float:
    return float(tip_error_mm(model.predict(session.q_cmd)[start:], session.q_phy[start:]).mean())


def run() -> Figures:
    figures: Figures = {}
    recordings = {name: _recording(name) for pair in SAME_ARM for name in pair}
    models = {}
    for name, recording in recordings.items():
        assert recording.arm is not None
        models[name] = new_model("physics", recording.arm).fit(recording)
    medians, worst = [], []
    for first, second in SAME_ARM:
        for old, new in ((first, second), (second, first)):
            session, prefix = recordings[new], f"{old}->{new}"
            start = session.head(TRAIN_FRACTION)
            assert session.arm is not None
            trained = new_model("physics", session.arm).fit(session.slice(0, start))
            none = float(tip_error_mm(session.q_cmd[start:], session.q_phy[start:]).mean())
            gain = none - _tip_mm(trained, session, start)

            figures[f"{prefix}.uncompensated.tip_mm"] = none
            figures[f"{prefix}.other.tip_mm"] = _tip_mm(models[old], session, start)
            figures[f"{prefix}.trained.tip_mm"] = none - gain
            first_n = refit(models[old], session, SAMPLES)[0]
            figures[f"{prefix}.refit_first.recovered"] = (none - _tip_mm(first_n, session, start)) / gain
            own = refit_at(trained, session, np.arange(SAMPLES), gains=False)[0]
            figures[f"{prefix}.refit_first_own_shape.recovered"] = (
                none - _tip_mm(own, session, start)
            ) / gain
            draws, offsets_only, factors = [], [], []
            for seed in range(DRAWS):
                rng = np.random.default_rng(seed)
                at = np.sort(rng.choice(start, SAMPLES, replace=False))
                refitted, report = refit_at(models[old], session, at)
                offsets = refit_at(models[old], session, at, gains=False)[0]
                draws.append((none - _tip_mm(refitted, session, start)) / gain)
                offsets_only.append((none - _tip_mm(offsets, session, start)) / gain)
                factors.append([joint.width_factor for joint in report])
            figures[f"{prefix}.refit.recovered_median"] = float(np.median(draws))
            figures[f"{prefix}.refit.recovered_worst"] = float(np.min(draws))
            figures[f"{prefix}.refit.tip_mm_median"] = none - float(np.median(draws)) * gain
            figures[f"{prefix}.refit_offsets_only.recovered_median"] = float(np.median(offsets_only))
            figures[f"{prefix}.refit.width_factors_median"] = ", ".join(
                f"{f:g}" for f in np.median(np.array(factors), axis=0)
            )
            medians.append(float(np.median(draws)))
            worst.append(float(np.min(draws)))
    figures["recovered_median_min"] = min(medians)
    figures["recovered_worst_min"] = min(worst)
    figures["samples"] = SAMPLES
    figures["draws"] = DRAWS
    return figures
