"""An arm stopped in the middle of a fast motion (a carry halted because its block slipped) moves on: its
next motion's first command is the set-point the arm holds, so the transport never refuses it as a jump,
with the calibrated condition's compensation, over real zenoh on loopback."""

from __future__ import annotations

import numpy as np
import pytest
from lockstep_helpers import lockstep_psm1

from pegbt.behaviours.resources.skills import SIMULATOR_CALIBRATION, Skills

TICK = 0.02  # the executive's tick


@pytest.fixture(scope="module")
def arm():
    """A lockstep simulator of the arms alone (dvrk-real cable physics), PSM1's client and its clock."""
    with lockstep_psm1("--physics", "dvrk-real") as stepped:
        yield stepped


@pytest.mark.parametrize("stop_after", [0.31, 0.47, 0.62])
def test_the_motion_after_a_stop_mid_way_starts_at_the_set_point_the_arm_holds(arm, stop_after):
    clock, psm1 = arm
    motion = Skills("calibrated", SIMULATOR_CALIBRATION).arm("PSM1")
    start = motion.start_from(psm1)
    far = start + [0.6, 0.25, 0.03, 0.8, 0.5, -0.5]  # fast in yaw, pitch and insertion at once
    first = motion.send(psm1, motion.through(start, [far], ["far"]))
    clock.wait(stop_after)
    assert first.busy
    motion.stop(psm1)  # as a carry does when its block slipped: at once, mid-way, at speed
    clock.wait(TICK)
    held = np.asarray(psm1.setpoint_js.position)
    back = motion.send(psm1, motion.through(motion.start_from(psm1), [start], ["back"]))
    # the set-point held, not one read earlier: that is up to a full step at top speed away
    assert np.max(np.abs(motion.active.sent.q[0] - held)) < 1e-9
    end = clock.now() + 5.0
    while back.busy and clock.now() < end:
        clock.wait(TICK)
    assert back.done, back.error
