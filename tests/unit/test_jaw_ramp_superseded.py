"""A CRTK jaw ramp to one goal superseded mid-way by a ramp to another: the robot's jaw set-point echoes the
rows streamed a few rows late, so a ramp from it stepped the jaw back by more than the velocity limit and
the streamer refused it. The new ramp takes over from the last row the streamer sent, and the robot receives
one continuous sequence of set-points, none further than the limit's step from the one before.

The client (`CrtkArm`) and the streamer's loop (`pegbt.transport.streamer.Streamer`) run in this process on
a fake robot wire; the test ticks the loop and echoes the set-points late, as a robot does."""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from pegbt.motion.limits import arm_settings
from pegbt.transport import codec, session, wires
from pegbt.transport import streamer as child
from pegbt.transport.crtk_arm import CrtkArm

SETTINGS = arm_settings("PSM1")
STEP = SETTINGS.jaw_velocity * SETTINGS.control_period  # the most a set-point may move in a period
LAG = 3  # rows the robot's jaw set-point echo comes behind the rows sent
OPEN, CLOSED = 0.5, -0.2


class Robot:
    """The wire both sides talk on: keeps each topic's subscribers and what was put on each topic."""

    def __init__(self) -> None:
        self.subscribers: dict[str, list[Callable[[bytes], None]]] = {}
        self.sent: dict[str, list[bytes]] = {}

    def publisher(self, topic: Any) -> Publisher:
        return Publisher(self.sent.setdefault(topic.name, []))

    def subscriber(self, topic: Any, on_payload: Callable[[bytes], None]) -> Robot:
        self.subscribers.setdefault(topic.name, []).append(on_payload)
        return self

    def says(self, topic: str, position: np.ndarray) -> None:
        for on_payload in self.subscribers.get(f"/PSM1/{topic}", []):
            on_payload(codec.encode_joint_state(0.0, position))

    def jaw_servo(self) -> list[float]:
        return [
            float(codec.decode_joint_state(p).position[0]) for p in self.sent.get("/PSM1/jaw/servo_jp", [])
        ]

    def echo(self) -> None:
        """Publish the jaw set-point `LAG` rows behind the last one received, and the joints (liveness)."""
        rows = self.jaw_servo()
        if len(rows) > LAG:
            self.says("jaw/setpoint_js", np.array([rows[-1 - LAG]]))
        self.says("measured_js", np.zeros(6))

    def settle(self) -> None:
        self.says("jaw/setpoint_js", np.array([self.jaw_servo()[-1]]))


class Publisher:
    def __init__(self, sent: list[bytes]) -> None:
        self._sent = sent

    def put(self, payload: bytes) -> None:
        self._sent.append(payload)


class Session:
    def close(self) -> None:
        pass


class Loop:
    """The executive's `Streamer` with the streamer's loop in this process: each frame is handled for the
    next tick, and the loop ticks when the test says."""

    running = True

    def __init__(self, robot: Robot) -> None:
        config = {
            "period": SETTINGS.control_period,
            "connect": [],
            "namespace": "",
            "arms": {"PSM1": SETTINGS},
        }
        self.reports: list[tuple[Any, ...]] = []
        self.streamer = child.Streamer(config, self.reports.append)
        self._ids = itertools.count(1)
        # far enough ahead of the monotonic clock that the loop never moves a motion's start to "now"
        self.next_tick = 2.0 ** math.ceil(math.log2(time.monotonic() + 600.0))

    def play(self, arm: str, axis: str, t: Any, q: Any) -> int:
        return self._handle(lambda motion_id: ("play", motion_id, arm, axis, np.asarray(t), np.asarray(q)))

    def ramp(self, arm: str, start: float, goal: float) -> int:
        return self._handle(lambda motion_id: ("ramp", motion_id, arm, start, goal))

    def _handle(self, frame: Callable[[int], tuple[Any, ...]]) -> int:
        motion_id = next(self._ids)
        assert self.streamer.handle(frame(motion_id), self.next_tick)
        return motion_id

    def stop(self, motion_id: int) -> None:
        self.streamer.handle(("stop", motion_id), self.next_tick)

    def tick(self) -> None:
        self.streamer.tick(self.next_tick)
        self.next_tick += SETTINGS.control_period

    def outcome(self, motion_id: int) -> tuple[str, str] | None:
        ends = [r for r in self.reports if r[0] in ("done", "failed") and r[1] == motion_id]
        return (ends[-1][0], ends[-1][2] if len(ends[-1]) > 2 else "") if ends else None

    def stalled(self, motion_id: int) -> float:
        return 0.0


@pytest.fixture
def rig(monkeypatch: pytest.MonkeyPatch) -> tuple[Robot, Loop, CrtkArm]:
    robot = Robot()
    monkeypatch.setattr(session, "open_session", lambda settings: Session())
    monkeypatch.setattr(wires, "make_wire", lambda kind, session, namespace, node_name: robot)
    loop = Loop(robot)
    client = CrtkArm(robot, "PSM1", settings=SETTINGS, streamer=loop)  # type: ignore[arg-type]
    robot.says("measured_js", np.zeros(6))
    robot.says("jaw/setpoint_js", np.array([OPEN]))
    return robot, loop, client


def play_out(robot: Robot, loop: Loop, rows: int) -> None:
    for _ in range(rows):
        loop.tick()
        robot.echo()


@pytest.mark.parametrize("goal", [0.9, -0.3, CLOSED], ids=["back-open", "further-closed", "same-goal"])
def test_a_ramp_superseded_mid_way_goes_on_from_the_last_row_sent(rig, goal: float) -> None:
    robot, loop, client = rig
    closing = client.jaw.move_jp(CLOSED)
    play_out(robot, loop, 6)  # half-way: the robot's set-point is LAG rows behind the last row sent
    assert abs(robot.jaw_servo()[-1] - float(client.jaw.setpoint_js.position[0])) > 2 * STEP
    second = client.jaw.move_jp(goal)
    assert (second is closing) == (goal == CLOSED)
    play_out(robot, loop, int(2 / STEP))  # more rows than the whole range takes
    robot.settle()

    sent = robot.jaw_servo()
    steps = np.abs(np.diff([OPEN, *sent]))
    assert steps.max() <= STEP * (1 + 1e-9), f"a step of {steps.max():.4f} rad, limit {STEP:.4f}"
    assert sent[-1] == goal
    assert second.done, second.error
    refused = [r for r in loop.reports if r[0] == "failed" and r[1] == second.motion_id]
    assert not refused
    assert len(loop.reports) == (2 if goal == CLOSED else 4)  # started, done; or replaced, started, done
