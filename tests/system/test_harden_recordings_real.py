"""The four real dVRK recordings load, though their wrists pass the limits."""

from __future__ import annotations

import pytest

from pegbt.physics.recording import load_recording

REAL = (
    "random_smooth_grey1_PSM1",
    "random_smooth_grey2_PSM2",
    "random_smooth_new1_PSM1",
    "random_smooth_new2_PSM2",
)


@pytest.mark.parametrize("name", REAL)
def test_the_four_real_recordings_load_though_their_wrists_pass_the_limits(dvrk_data, name):
    recording = load_recording(dvrk_data / name)
    assert recording.n > 1000 and recording.arm == name[-4:]
