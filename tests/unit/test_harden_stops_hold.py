"""A stop is a command the endpoint always accepts: a hold is accepted in a fast move where a servo at a stale
set-point is refused; a hold that names its motion stops no later one."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import SimArm
from pegbt.sim.commands import CommandIntake, dispatch
from pegbt.sim.fault_plan import FaultInjector, FaultPlan
from pegbt.sim.log import SimLog
from pegbt.transport import codec
from pegbt.transport.keys import ArmKeys
from pegbt.transport.sequencing import Source


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


def test_a_hold_that_overtook_nothing_but_arrives_after_the_next_goal_leaves_that_goal_be():
    """Zenoh keeps no order across keys: a client stops its jaw closing (`jaw/hold`, naming the close in
    its tag) and opens it (`jaw/move_jp`) in one tick, and the open may arrive first. The late hold has
    nothing left to stop; the open plays on. A hold that names nothing stops whatever runs."""
    arm = SimArm("PSM1", arm_settings("PSM1"), ArmPhysics())
    keys, intake = ArmKeys("PSM1"), CommandIntake(FaultInjector(FaultPlan()), SimLog())
    client = Source("client")

    def arrives(key: str, payload: bytes, cause: str = "") -> list[tuple[str, str]]:
        command = intake.admit("PSM1", key, payload, client.next_tag(key, cause), 0.0, 0.0)
        assert command is not None
        return [(t.command_id, t.outcome) for t in dispatch(arm, keys, command)]

    def jaw_goal(angle: float) -> bytes:
        return codec.encode_joint_state(0.0, np.array([angle]))

    close = f"client:{keys.jaw_move_jp}:1"
    assert arrives(keys.jaw_move_jp, jaw_goal(-0.26)) == [(close, "accepted")]
    arm.advance(arm.period)
    assert arm.is_busy  # still closing
    open_ = f"client:{keys.jaw_move_jp}:2"
    assert arrives(keys.jaw_move_jp, jaw_goal(0.52)) == [(close, "aborted"), (open_, "accepted")]
    assert arrives(keys.jaw_hold, codec.encode_empty(), cause=close) == [
        (f"client:{keys.jaw_hold}:1", "done")
    ]
    done = [t.outcome for _ in range(200) for t in arm.advance(arm.period)]
    assert done == ["done"] and arm.jaw.setpoint[0] == pytest.approx(0.52)
    # a hold naming no motion (a dVRK's, a ROS 2 bridge's) stops the one running, as before
    assert arrives(keys.jaw_move_jp, jaw_goal(0.0))[-1] == (f"client:{keys.jaw_move_jp}:3", "accepted")
    assert arrives(keys.jaw_hold, codec.encode_empty()) == [
        (f"client:{keys.jaw_move_jp}:3", "aborted"),
        (f"client:{keys.jaw_hold}:2", "done"),
    ]
