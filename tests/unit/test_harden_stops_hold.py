"""A stop is a command the endpoint always accepts: a hold is accepted in a fast move where a servo at a stale
set-point is refused."""

from __future__ import annotations

import numpy as np

from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import SimArm


def test_a_hold_is_accepted_in_a_fast_move_where_a_servo_at_a_stale_set_point_is_refused():
    settings = arm_settings("PSM1")
    arm = SimArm("PSM1", settings, ArmPhysics())
    start = arm.joints.setpoint.copy()
    goal = np.array([-1.2, *start[1:]])  # a long yaw move: at its middle it nears 2 rad/s
    assert [t.outcome for t in arm.move_jp(goal, "move")] == ["accepted"]
    seen = []
    for _ in range(round(0.6 / arm.period)):  # into the fast middle of the move
        arm.advance(arm.period)
        seen.append(arm.joints.setpoint.copy())
    stale = seen[-3]  # the set-point a client received two ticks ago
    refused = arm.servo_jp(stale, "stop by servo")
    assert refused[-1].outcome == "refused" and "would move at" in refused[-1].text
    transitions = arm.hold(False, "stop by hold")
    assert [(t.command_id, t.outcome) for t in transitions] == [("move", "aborted"), ("stop by hold", "done")]
    held = arm.joints.setpoint.copy()
    for _ in range(20):
        arm.advance(arm.period)
    assert np.array_equal(arm.joints.setpoint, held) and not arm.is_busy
