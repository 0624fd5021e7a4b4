"""`pegbt bench calibration-refit`: recalibrating a re-homed arm from its first 20 set-points.

For each pair of set-ups of the same arm in the dVRK recordings (both ways), the tip error (mean, mm,
through forward kinematics) of the physics model's prediction on the last 30 % of the new session: no
compensation, the other set-up's model (trained on all of it), that model refitted on the new session's
first `SAMPLES` set-points (offsets and gains, `pegbt.calibration.refit`), and a model trained on the new
session's first 70 %. `recovered` is the refit's share of the trained model's gain over no compensation
(goal: at least 0.8). Beside them, what tells where the rest is: offsets alone refitted on the same
set-points, and the refit on `MORE` set-points and on the whole first 70 % (offsets alone, and with gains).
"""

from __future__ import annotations

from pegbt.bench import Figures
from pegbt.calibration.base import new_model
from pegbt.calibration.evaluation import evaluate
from pegbt.calibration.refit import refit
from pegbt.physics.recording import Recording, dvrk_data_dir, load_recording

SAME_ARM = (("grey1_PSM1", "new1_PSM1"), ("grey2_PSM2", "new2_PSM2"))
SAMPLES = 20
MORE = 100
TRAIN_FRACTION = 0.7


def _recording(name: str) -> Recording:
    return load_recording(dvrk_data_dir(required=True) / f"random_smooth_{name}")


def run() -> Figures:
    figures: Figures = {}
    recordings = {name: _recording(name) for pair in SAME_ARM for name in pair}
    models = {}
    for name, recording in recordings.items():
        assert recording.arm is not None
        models[name] = new_model("physics", recording.arm).fit(recording)
    recovered = []
    for first, second in SAME_ARM:
        for old, new in ((first, second), (second, first)):
            session = recordings[new]
            start = session.head(TRAIN_FRACTION)
            assert session.arm is not None
            trained = new_model("physics", session.arm).fit(session.slice(0, start))
            refitted, moved = refit(models[old], session, SAMPLES)
            scores = {
                "other": evaluate(models[old], session, start),
                "refit": evaluate(refitted, session, start),
                "trained": evaluate(trained, session, start),
                "refit_offsets_only": evaluate(
                    refit(models[old], session, SAMPLES, gains=False)[0], session, start
                ),
                f"refit_{MORE}": evaluate(refit(models[old], session, MORE)[0], session, start),
                "refit_offsets_only_70pct": evaluate(
                    refit(models[old], session, start, gains=False)[0], session, start
                ),
                "refit_70pct": evaluate(refit(models[old], session, start)[0], session, start),
            }
            figures[f"{old}->{new}.refit.gains_refitted_on"] = (
                ", ".join(m.joint for m in moved if m.prior != float("inf")) or "none"
            )
            prefix = f"{old}->{new}"
            none = float(scores["other"]["tip_err_mm_mean_uncompensated"])
            figures[f"{prefix}.uncompensated.tip_mm"] = none
            for label, score in scores.items():
                figures[f"{prefix}.{label}.tip_mm"] = float(score["tip_err_mm_mean"])
            gain = none - float(scores["trained"]["tip_err_mm_mean"])
            for label in scores:
                if label not in ("other", "trained"):
                    share = (
                        (none - float(scores[label]["tip_err_mm_mean"])) / gain if gain > 0 else float("nan")
                    )
                    figures[f"{prefix}.{label}.recovered"] = share
            recovered.append(figures[f"{prefix}.refit.recovered"])
    figures["recovered_min"] = min(recovered)
    figures["samples"] = SAMPLES
    return figures
