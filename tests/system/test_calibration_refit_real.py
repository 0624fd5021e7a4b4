"""Recalibrating a re-homed arm on the real recordings: 20 spread set-points recover most of what a model
trained on the new session gains."""

import numpy as np
import pytest

from pegbt.calibration.base import new_model
from pegbt.calibration.evaluation import evaluate
from pegbt.calibration.refit import refit_at
from pegbt.physics.recording import load_recording


@pytest.mark.slow
def test_on_real_recordings_20_spread_set_points_recover_most_of_a_model_trained_on_the_new_session(
    dvrk_data,
):
    """grey1 → new1, the pair whose set-ups differ most (the wrist's play 0.15–0.36 rad against 0.03): two
    draws of 20 set-points from the new session's first 70 %, scored on its last 30 %."""
    old_session, session = (
        load_recording(dvrk_data / f"random_smooth_{n}") for n in ("grey1_PSM1", "new1_PSM1")
    )
    old = new_model("physics", "PSM1").fit(old_session)
    start = session.head(0.7)
    trained = new_model("physics", "PSM1").fit(session.slice(0, start))
    none = evaluate(trained, session, start)["tip_err_mm_mean_uncompensated"]
    gain = none - evaluate(trained, session, start)["tip_err_mm_mean"]
    for seed in (0, 1):
        at = np.sort(np.random.default_rng(seed).choice(start, 20, replace=False))
        refitted, report = refit_at(old, session, at)
        assert (none - evaluate(refitted, session, start)["tip_err_mm_mean"]) / gain >= 0.8
        assert {j.joint: j.width_factor for j in report}["q5"] < 1  # new1's wrist play is narrower
    offsets_only = refit_at(old, session, at, gains=False)[0]
    assert evaluate(offsets_only, session, start)["tip_err_mm_mean"] > none  # the old widths do harm
