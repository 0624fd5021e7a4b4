"""A real dVRK's first minutes, against the simulator's dVRK interface (`pegbt sim --interface dvrk`, checked
by an independent peer where it says what the robot sends) and against the CRTK double (`crtk_double.py`):
joints invalid until the encoders are biased, a robot computer whose clock is an hour off, the clutch
(MANUAL) mid-motion, and latched messages from before the run. Each runs a robot in real time for seconds
(homing, motions, the clutch held): the system tier, as `test_sim_dvrk.py`. What is refused before anything
moves is in `tests/integration/test_dvrk_first_refusals.py`."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from crtk_double import CrtkDouble
from dvrk_peer import STORE, DvrkPeer, Received, state_command, wait_for
from dvrk_sim_helpers import ServedSim

from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.behaviours.resources.robot import Robot, connect_crtk_robot
from pegbt.executive.analysis import summary
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.sim.process import free_port
from pegbt.transport.arm import ArmLeftReady
from pegbt.transport.crtk_arm import rest_to_rest_bound

pytestmark = pytest.mark.system

HOUR = 3600.0
JOINT_STATE = "sensor_msgs/msg/JointState"
OPERATING_STATE = "crtk_msgs/msg/OperatingState"
HELD_STILL = 0.3  # s before the clutch's release (held 1.2 s) in which no servo_jp may reach the robot
STILL_SAMPLES = 5  # set-points the simulated robot publishes unchanged just before the release, at least


class Robots:
    """The simulator's dVRK interface or the CRTK double at `address`, with what a test does to each."""

    def __init__(self, kind: str, tmp_path: Path, clock_offset: float = 0.0, old_errors: int = 0) -> None:
        self.kind = kind
        if kind == "sim":
            self.sim: ServedSim | None = ServedSim(tmp_path / "sim.jsonl", robot_clock_offset=clock_offset)
            self.address = self.sim.address
            self.double: CrtkDouble | None = None
            self.peer = DvrkPeer(self.address)
            for _ in range(old_errors):  # each an unknown state command: a warning, latched
                self.peer.put("PSM1/state_command", state_command("dance"))
        else:
            self.sim = None
            self.address = f"tcp/127.0.0.1:{free_port()}"
            self.double = CrtkDouble(self.address, clock_offset=clock_offset, old_errors=old_errors)
            self.peer = DvrkPeer(self.address)

    def clutch(self, arm: str, pressed: bool) -> None:
        """A person presses or releases the clutch: the simulator's documented stand-in for the button
        (`/pegbt_sim/PSMn/arm_clutch`, sensor_msgs/Joy), or the double's."""
        if self.double is not None:
            self.double.clutch(arm, pressed)
            return
        now = time.time()
        header = STORE.types["std_msgs/msg/Header"](
            stamp=STORE.types["builtin_interfaces/msg/Time"](sec=int(now), nanosec=0), frame_id=""
        )
        joy = STORE.types["sensor_msgs/msg/Joy"](
            header=header, axes=np.zeros(0, np.float32), buttons=np.array([int(pressed)], np.int32)
        )
        self.peer.put(f"pegbt_sim/{arm}/arm_clutch", joy)

    def close(self) -> None:
        self.peer.close()
        if self.sim is not None:
            self.sim.close()
        if self.double is not None:
            self.double.close()


@pytest.fixture
def robots(tmp_path: Path) -> Iterator[Callable[..., Robots]]:
    made: list[Robots] = []

    def make(kind: str, **kwargs: Any) -> Robots:
        made.append(Robots(kind, tmp_path, **kwargs))
        return made[-1]

    yield make
    for robot in made:
        robot.close()


def test_joints_are_invalid_until_the_encoders_are_biased_then_seven_until_the_tool_engages(
    tmp_path: Path,
) -> None:
    sim = ServedSim(tmp_path / "sim.jsonl", robot_clock_offset=HOUR)
    peer = DvrkPeer(sim.address)
    try:
        measured = peer.subscribe("PSM1/measured_js")
        states = peer.subscribe_latched("PSM1/operating_state")
        assert wait_for(lambda: measured.all())
        first = measured.decoded(JOINT_STATE)[-1]
        assert (first.header.stamp.sec, first.header.stamp.nanosec) == (0, 0)  # invalid: stamp 0
        assert len(first.position) == 7 and not np.any(first.position)  # the PID's seven joints, zeros
        peer.put("PSM1/state_command", state_command("enable"))
        peer.put("PSM1/state_command", state_command("home"))
        assert wait_for(lambda: (s := states.decoded(OPERATING_STATE)) and s[-1].is_homed, timeout=20)
        time.sleep(0.1)
        seen = measured.decoded(JOINT_STATE)
        last = seen[-1]
        assert len(last.position) == 6 and list(last.name)[:3] == ["yaw", "pitch", "insertion"]
        stamp = last.header.stamp.sec + last.header.stamp.nanosec * 1e-9
        assert stamp == pytest.approx(time.time() + HOUR, abs=2.0)  # the robot's clock, an hour ahead
        homing = list(states.decoded(OPERATING_STATE))
        assert all(s.header.stamp.sec > time.time() + HOUR - 60 for s in homing)
        assert [(s.state, s.is_busy) for s in homing][:3] == [
            ("DISABLED", False),
            ("DISABLED", True),  # powering
            ("ENABLED", False),
        ]
        assert sum(s.is_busy for s in homing) >= 3  # powering, calibrating from pots, homing, engaging
    finally:
        peer.close()
        sim.close()


@pytest.mark.parametrize("offset", [-HOUR, HOUR], ids=["robot clock 1 h behind", "robot clock 1 h ahead"])
@pytest.mark.parametrize("kind", ["sim", "double"])
def test_the_first_homing_after_start_up_ends_whatever_the_robot_clock(
    robots: Callable[..., Robots], kind: str, offset: float
) -> None:
    """Until the encoders are biased the robot sends joints stamped 0; homing is judged by what the robot
    stamped, never against this computer's clock (before: 'did not home within 60 s' an hour behind)."""
    robot = robots(kind, clock_offset=offset)
    client = connect_crtk_robot(robot.address, liveness=5.0)
    try:
        arm = client.arm("PSM1")
        assert arm.operating_state.is_homed and arm.operating_state.stamp == pytest.approx(
            time.time() + offset, abs=60
        )
        goal = arm.setpoint_js.position + np.array([0.0, 0.0, -0.01, 0.0, 0.0, 0.0])
        move = arm.move_jp(goal)
        assert move.busy
        assert wait_for(lambda: not move.busy, 20) and move.done, move.error
    finally:
        client.close()


def _clutched_mid_motion(
    robot: Robots, seen: Callable[[float], bool] = lambda pressed: True
) -> tuple[Robot, Any, float, float, float]:
    """A 2.4 s motion of PSM1 streamed, its clutch pressed 0.5 s in and released 1.2 s later (the arm has
    ~0.25 rad of yaw left then: a motion that did not pause would jump by more than the checks allow), or
    once the peer has `seen` what the test judges the hold by, when a loaded machine delays it (a motion
    that did not pause has then ended, which the check that it went on after the release catches); the
    client, the motion, the monotonic times of press and release, and the motion's top speed on q1-q2 (rad/s)."""
    client = connect_crtk_robot(robot.address, liveness=5.0)
    arm = client.arm("PSM1")
    motion = ArmMotion(arm.settings.at_speed(0.3))
    start = arm.setpoint_js.position
    goal = start + np.array([0.28, -0.14, 0.014, 0.0, 0.0, 0.0])
    trajectory = motion.through(start, [goal], ["goal"])
    assert trajectory.t[-1] > 2.0
    handle = arm.move_jp(trajectory)
    time.sleep(0.5)
    pressed = time.monotonic()
    robot.clutch("PSM1", True)
    time.sleep(1.2)
    assert wait_for(lambda: seen(pressed), 10.0), "the peer saw too little of the hold"
    assert handle.busy, handle.error  # paused, not failed
    released = time.monotonic()
    robot.clutch("PSM1", False)
    assert wait_for(lambda: not handle.busy, 20) and handle.done, handle.error
    # done once its last set-point is sent and taken up: the robot's own set-point echoes the goal after, within
    # the liveness the client allows a simulator on a loaded machine
    assert wait_for(lambda: np.allclose(arm.setpoint_js.position, goal, atol=1e-6), 5.0)
    arm.check_alive()  # ENABLED and homed all along: nothing stopped the run
    return client, handle, pressed, released, float(np.abs(trajectory.qd[:, :2]).max())


def _manual_from(states: Received, pressed: float) -> float | None:
    """When the peer first saw the arm busy (MANUAL) after `pressed`, if it has."""
    return next(
        (
            at
            for at, s in states.samples
            if at > pressed and STORE.deserialize_cdr(s.payload, OPERATING_STATE).is_busy
        ),
        None,
    )


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["sim", "double"])
def test_the_clutch_mid_motion_pauses_it_and_it_completes_after_release_without_a_jump(
    robots: Callable[..., Robots], kind: str
) -> None:
    robot = robots(kind)
    setpoints = robot.peer.subscribe("PSM1/setpoint_js")
    states = robot.peer.subscribe_latched("PSM1/operating_state")
    measured = robot.peer.subscribe("PSM1/measured_js")

    def held_long_enough(pressed: float) -> bool:
        """More than `STILL_SAMPLES` of the simulated robot's set-points arrived after the peer saw MANUAL."""
        manual = _manual_from(states, pressed)
        return manual is not None and sum(at > manual for at, _ in setpoints.samples) > STILL_SAMPLES

    clutched = (
        _clutched_mid_motion(robot, held_long_enough) if robot.double is None else _clutched_mid_motion(robot)
    )
    client, _, pressed, released, speed = clutched
    try:
        manual_from = _manual_from(states, pressed)
        assert manual_from is not None, "the arm never said MANUAL (busy)"
        messages = client.log_messages()
        assert any("MANUAL" in m["text"] for m in messages), [m["text"] for m in messages][-20:]
        if robot.double is not None:  # what the robot received
            sent = [(r.at, np.asarray(r.message.position)) for r in robot.double.commands("PSM1/servo_jp")]
        else:  # what the robot's set-point did: it moves with every servo_jp, MANUAL or not
            sent = [
                (at, np.asarray(STORE.deserialize_cdr(s.payload, JOINT_STATE).position))
                for at, s in setpoints.samples
            ]
        sent = [(at, q) for at, q in sent if len(q) == 6]
        # a loaded machine may leave the simulated robot working through set-points sent before the client saw
        # MANUAL for most of a second; however late, the set-point then stands exactly where MANUAL stopped the
        # arm until the release, where a client that streamed on would move it ~1 mrad a set-point (its motion
        # has over 1 s left at the release)
        held = [q for at, q in sent if manual_from < at < released]
        if robot.double is None:
            still = held[-STILL_SAMPLES:]
            assert len(still) == STILL_SAMPLES and np.ptp(np.array(still), axis=0).max() < 1e-9, held[-20:]
        else:  # what the robot received
            assert not [q for at, q in sent if released - HELD_STILL < at < released]
        after = [q for at, q in sent if at > released + 0.1]
        assert np.ptp(np.array(after), axis=0).max() > 0.01  # streaming went on after the release
        decoded = [STORE.deserialize_cdr(s.payload, JOINT_STATE).position for _, s in measured.samples]
        positions = np.array([p for p in decoded if len(p) == 6])
        steps = np.abs(np.diff(positions, axis=0))
        assert steps[:, :2].max() < 0.1 and steps[:, 2].max() < 0.01  # rad, m between two states: no jump
        # nor in the set-points: a step beyond what the motion's speed covers in the time between two of them
        # (a loaded machine's stall spaces them), 0.05 rad spare; a resume that skipped the pause jumps ~0.25
        times, path = np.array([at for at, _ in sent]), np.array([q for _, q in sent])
        excess = np.abs(np.diff(path, axis=0))[:, :2].max(axis=1) - speed * np.diff(times)
        assert excess.max() < 0.05, excess.max()
    finally:
        client.close()


@pytest.mark.parametrize("kind", ["sim", "double"])
def test_speed_slows_the_robots_own_move_jp_through_its_trajectory_ratios(
    robots: Callable[..., Robots], kind: str
) -> None:
    """`--speed 0.5`: before homing the client sets the robot's `trajectory_j` ratios (velocity 0.5,
    acceleration 0.25) and the robot confirms them; its own `move_jp` then takes twice as long."""
    robot = robots(kind)
    ratios = {kind: robot.peer.subscribe_latched(f"PSM1/trajectory_j/ratio_{kind}") for kind in "va"}
    client = connect_crtk_robot(robot.address, liveness=5.0, speed=0.5)
    try:
        for which, ratio in (("v", 0.5), ("a", 0.25)):
            assert [m.data for m in ratios[which].decoded("std_msgs/msg/Float64")][-1] == ratio
        arm = client.arm("PSM1")
        start = arm.setpoint_js.position
        goal = start + np.array([0.6, 0.0, 0.0, 0.0, 0.0, 0.0])
        began = time.monotonic()
        move = arm.move_jp(goal)
        assert wait_for(lambda: not move.busy, 20) and move.done, move.error
        took = time.monotonic() - began
        if robot.double is None:  # the dVRK's profile: 1.24 s at full speed, 2.47 s at half
            full = rest_to_rest_bound(start, goal)
            assert took > 1.8 * full, (took, full)
        else:
            assert took > 1.8 * robot.double.move_seconds
    finally:
        client.close()


@pytest.mark.parametrize("kind", ["sim", "double"])
def test_the_clutch_button_is_reported_on_the_io_topic_a_dvrk_2_4_publishes(
    robots: Callable[..., Robots], kind: str
) -> None:
    """Each press and release on `PSMn/IO/arm_clutch` (sensor_msgs/Joy: 1, then 0), the arm MANUAL between
    them; a press on an arm not ready is reported too, though the arm ignores it."""
    robot = robots(kind)
    buttons = robot.peer.subscribe_latched("PSM1/IO/arm_clutch")
    robot.clutch("PSM1", True)  # DISABLED: the IO board reports it, the arm ignores it
    robot.clutch("PSM1", False)
    client = connect_crtk_robot(robot.address, liveness=5.0)
    try:
        robot.clutch("PSM1", True)
        manual = client.arm("PSM1").operating_state
        assert wait_for(lambda: client.arm("PSM1").operating_state.is_busy, 5), "never MANUAL"
        assert manual.state == "ENABLED" and manual.is_homed
        robot.clutch("PSM1", False)
        assert wait_for(lambda: not client.arm("PSM1").operating_state.is_busy, 5)
        assert wait_for(lambda: len(buttons.all()) >= 4, 5)
        pressed = [int(m.buttons[0]) for m in buttons.decoded("sensor_msgs/msg/Joy")]
        assert pressed == [1, 0, 1, 0]
    finally:
        client.close()


@pytest.mark.parametrize("kind", ["sim", "double"])
def test_messages_latched_before_the_run_are_history_never_a_stops_cause(
    robots: Callable[..., Robots], kind: str, tmp_path: Path
) -> None:
    robot = robots(kind, old_errors=100)
    level = "error" if kind == "double" else "warning"
    if kind == "sim":  # 100 warnings said before the client joined

        def cached() -> bool:
            """Whether a subscriber joining now is sent all 100: its history comes after it joins, not at once."""
            history = robot.peer.subscribe_latched("PSM1/warning")
            return wait_for(lambda: len(history.all()) >= 100, timeout=2.0)

        assert wait_for(cached, timeout=30.0)
        client = connect_crtk_robot(robot.address, liveness=5.0)
        try:
            messages = client.log_messages()
        finally:
            client.close()
        old = [m for m in messages if m["source"] == "PSM1" and m["level"] == level]
        assert len(old) == 100 and all(m.get("before_run") is True for m in old)
        assert all(not m.get("before_run") for m in messages if "power on" in m["text"])
        return
    tree = tmp_path / "look.yaml"
    tree.write_text("doc: one capture from the robot's camera\ntree:\n  capture: {}\n")
    output = run_tree_file(
        RunOptions(
            tree,
            tmp_path / "look.jsonl",
            {"interface": "dvrk", "endpoint": robot.address, "condition": "uncalibrated", "liveness": 5.0},
            timeout=60,
        ),
        quiet=True,
    )
    assert output.result.outcome == "success"
    records = [json.loads(line) for line in (tmp_path / "look.jsonl").read_text().splitlines()]
    old = [r for r in records if r["type"] == "message" and r["source"] == "PSM1" and r["level"] == level]
    assert len(old) == 100 and all(r.get("before_run") is True for r in old)
    current = [r for r in records if r["type"] == "message" and not r.get("before_run")]
    assert current and all("old error" not in r["text"] for r in current)
    text = summary(read_tick_log(tmp_path / "look.jsonl"))
    assert "200 from before this run" in text and "old error" not in text
    client = connect_crtk_robot(robot.address, liveness=5.0)  # a stop's cause is never the history
    try:
        assert robot.double is not None
        robot.double.console("PSM1", "disable")
        with pytest.raises(ArmLeftReady) as stopped:
            wait_for(lambda: client.arm("PSM1").check_alive(), 5)
        assert "old error" not in str(stopped.value)
    finally:
        client.close()
