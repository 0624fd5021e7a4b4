"""When a streamed arm trajectory counts as done against a CRTK robot: once the streamer has sent its last
set-point and the robot's `setpoint_js` is within the step the next trajectory may start from (the
robot's own check of a trajectory's start), not only once the echo of that last row itself has come, a
state message later; a jaw ramp likewise, at the jaw's velocity."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pegbt.motion.limits import arm_settings
from pegbt.transport import codec
from pegbt.transport.crtk_arm import CrtkArm
from pegbt.transport.guards import step_problems


class Wire:
    """Keeps each topic's callback, so the test can play what the robot publishes."""

    def __init__(self) -> None:
        self.topics: dict[str, Callable[[bytes], None]] = {}

    def publisher(self, topic: object) -> Wire:
        return self

    def subscriber(self, topic: object, on_payload: Callable[[bytes], None]) -> Wire:
        self.topics[topic.name] = on_payload  # type: ignore[attr-defined]
        return self

    def put(self, payload: bytes) -> None:
        pass

    def robot_says(self, topic: str, position: np.ndarray) -> None:
        self.topics[f"/{topic}"](codec.encode_joint_state(0.0, position))


class Streamer:
    """A streamer that has sent every set-point of every motion it was handed."""

    running = True

    def __init__(self) -> None:
        self.played: list[tuple[str, str, int, np.ndarray, np.ndarray]] = []
        self.ramps: list[tuple[str, float, float]] = []  # each jaw ramp's arm, start and goal

    def play(self, arm: str, axis: str, t: object, q: object) -> int:
        self.played.append((arm, axis, len(self.played) + 1, np.asarray(t), np.asarray(q)))
        return len(self.played) + len(self.ramps)

    def ramp(self, arm: str, start: float, goal: float) -> int:
        self.ramps.append((arm, start, goal))
        return len(self.played) + len(self.ramps)

    def outcome(self, motion_id: int) -> tuple[str, str]:
        return ("done", "")

    def stalled(self, motion_id: int) -> float:
        return 0.0


def arm() -> tuple[CrtkArm, Wire]:
    wire = Wire()
    client = CrtkArm(wire, "PSM1", settings=arm_settings("PSM1"), streamer=Streamer())  # type: ignore[arg-type]
    return client, wire


def test_an_arm_trajectory_is_done_once_the_robots_set_point_is_a_start_the_next_one_may_take() -> None:
    client, wire = arm()
    settings = client.settings
    end = np.array([0.1, -0.05, 0.12, 0.2, 0.1, -0.1])
    row_before = end - 0.2 * settings.velocity * settings.control_period  # slowing to rest at the end
    assert not step_problems(end, row_before, settings, settings.control_period)
    wire.robot_says("PSM1/measured_js", row_before)
    wire.robot_says("PSM1/setpoint_js", row_before)
    handle = client.stream("arm", np.array([0.0, 0.01]), np.array([row_before, end]), "PSM1 trajectory", 0.01)
    assert handle.done  # the echo of the last row is not waited for

    far = end - 3.0 * settings.velocity * settings.control_period  # three steps at the limits away
    wire.robot_says("PSM1/setpoint_js", far)
    handle = client.stream("arm", np.array([0.0, 0.03]), np.array([far, end]), "PSM1 trajectory", 0.03)
    assert handle.busy  # the robot has not taken the end: the next trajectory would be refused its start


def test_a_jaw_ramp_is_done_once_the_robots_set_point_is_within_a_step_and_the_next_starts_at_its_goal() -> (
    None
):
    """A jaw ramp waited for the echo of its last row, a state message after it went: each jaw-only leaf (a
    handover's release) took that much longer than lockstep. Done a step short, the next ramp must still
    start where the last one ended, not step the jaw back to the row before."""
    client, wire = arm()
    step = client.settings.jaw_velocity * client.settings.control_period
    wire.robot_says("PSM1/measured_js", np.zeros(6))
    wire.robot_says("PSM1/jaw/setpoint_js", np.array([0.5 - 0.9 * step]))
    handle = client.jaw.move_jp(0.5)
    assert handle.done  # the echo of the last row is not waited for
    assert client.jaw.move_jp(0.2)
    assert client._streamer.ramps[-1] == ("PSM1", 0.5, 0.2)  # type: ignore[attr-defined]  # from the goal

    wire.robot_says("PSM1/jaw/setpoint_js", np.array([0.2 - 3 * step]))  # three steps short: not taken up
    assert client.jaw.move_jp(0.2).busy


class Playing(Streamer):
    """A streamer still sending every motion it was handed."""

    def outcome(self, motion_id: int) -> None:  # type: ignore[override]
        return None


def test_a_jaw_asked_for_the_goal_its_ramp_is_still_playing_toward_keeps_that_ramp() -> None:
    """The robot's set-point lags the rows streamed: a second ramp to the same goal started from it stepped
    the jaw back by twice the limit, the robot refused it and the handover's grasp failed."""
    wire = Wire()
    client = CrtkArm(wire, "PSM1", settings=arm_settings("PSM1"), streamer=Playing())  # type: ignore[arg-type]
    wire.robot_says("PSM1/measured_js", np.zeros(6))
    wire.robot_says("PSM1/jaw/setpoint_js", np.array([0.5]))
    closing = client.jaw.move_jp(-0.26)
    assert closing.busy
    wire.robot_says("PSM1/jaw/setpoint_js", np.array([0.2]))
    assert client.jaw.move_jp(-0.26) is closing
    assert len(client._streamer.ramps) == 1  # type: ignore[attr-defined]
    assert client.jaw.move_jp(0.5) is not closing  # another goal: a ramp of its own
