"""A hold names the motion it stops, and the simulator stops only that one: zenoh keeps the order of one
key's messages but not across keys, so a hold and the motion sent after it in the same lockstep step (a
leaf halted, the next leaf's motion sent) reach the simulator in either order. Under load the new motion
came first, the late hold aborted it, and the same seed gave another trial."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import SimArm
from pegbt.sim.commands import Command, CommandIntake, dispatch
from pegbt.sim.fault_plan import FaultInjector, FaultPlan
from pegbt.sim.log import SimLog
from pegbt.transport import codec
from pegbt.transport.arm import MotionHandle, MotionStatus
from pegbt.transport.keys import ArmKeys
from pegbt.transport.sequencing import Tag

ARM = "PSM1"


def _goal(arm: SimArm, yaw: float) -> bytes:
    return codec.encode_joint_state(0.0, np.array([yaw, *arm.joints.setpoint[1:]]))


def _played(hold_first: bool) -> tuple[list[tuple[str, str]], list[np.ndarray]]:
    """A long move, stopped by a hold naming it while a second move is sent after the hold on another
    key; the simulator takes the two in the order given. What became of the commands, and the set-points."""
    arm, keys = SimArm(ARM, arm_settings(ARM), ArmPhysics()), ArmKeys(ARM, "")
    intake = CommandIntake(FaultInjector(FaultPlan()), SimLog())

    def admit(key: str, payload: bytes, seq: int, cause: str = "") -> Command:
        command = intake.admit(ARM, key, payload, Tag("client", seq, cause), 0.0, 0.0)
        assert command is not None
        return command

    first = admit(keys.move_jp, _goal(arm, -1.2), 1)
    outcomes = [(t.command_id, t.outcome) for t in dispatch(arm, keys, first)]
    for _ in range(30):
        outcomes += [(t.command_id, t.outcome) for t in arm.advance(arm.period)]
    hold = admit(keys.hold, codec.encode_empty(), 1, cause=first.command_id)
    second = admit(keys.move_jp, _goal(arm, 0.3), 2)
    for command in (hold, second) if hold_first else (second, hold):
        outcomes += [(t.command_id, t.outcome) for t in dispatch(arm, keys, command)]
    setpoints = []
    for _ in range(150):
        outcomes += [(t.command_id, t.outcome) for t in arm.advance(arm.period)]
        setpoints.append(arm.joints.setpoint.copy())
    return outcomes, setpoints


def test_a_hold_arriving_after_the_motion_sent_after_it_leaves_that_motion_playing() -> None:
    in_order, late_hold = _played(hold_first=True), _played(hold_first=False)
    second = f"client:{ArmKeys(ARM, '').move_jp}:2"
    for outcomes, _ in (in_order, late_hold):
        assert (second, "done") in outcomes and (second, "aborted") not in outcomes
    assert np.array_equal(np.array(in_order[1]), np.array(late_hold[1]))


def test_a_hold_naming_no_motion_stops_whatever_plays() -> None:
    arm, keys = SimArm(ARM, arm_settings(ARM), ArmPhysics()), ArmKeys(ARM, "")
    arm.move_jp(np.array([-1.2, *arm.joints.setpoint[1:]]), "move")
    arm.advance(arm.period)
    hold = Command(ARM, keys.hold, codec.encode_empty(), "untagged:hold:1")
    assert [(t.command_id, t.outcome) for t in dispatch(arm, keys, hold)] == [
        ("move", "aborted"),
        ("untagged:hold:1", "done"),
    ]


def test_stopping_a_motion_sends_a_hold_naming_it() -> None:
    held: list[str] = []
    state = codec.OperatingState(0.0, "ENABLED", True, True)
    axis = SimpleNamespace(
        outcomes=SimpleNamespace(of=lambda command_id: None),
        arm_state=lambda: SimpleNamespace(tag=Tag("sim", 1), value=state),
        hold=lambda stopping="": held.append(stopping),
    )
    handle = MotionHandle(axis, "client:psm1/follow_jt:7", 0.0, "trajectory")  # type: ignore[arg-type]
    handle.stop()
    assert held == ["client:psm1/follow_jt:7"] and handle.status is MotionStatus.FAILED
