"""The executive against a CRTK robot (`--interface dvrk`), over real zenoh on loopback, against a robot double
written with raw zenoh and rosbags (`crtk_double.py`): enable and home, latched state, CRTK's completion rule,
the servo streamer, the robot's messages in the tick log, a streaming camera; and never a simulator key,
a pegbt extension topic or an attachment."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import zenoh
from crtk_double import LOWER, UPPER, CrtkDouble

from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.behaviours.resources.robot import connect_crtk_robot
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.executive.analysis import summary
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.motion.limits import arm_settings
from pegbt.sim.process import free_port
from pegbt.transport.arm import EndpointSilent
from pegbt.transport.camera import ColouredPoints
from pegbt.transport.crtk_arm import CrtkArm, make_ready
from pegbt.transport.guards import CommandRefused
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import client_settings, open_session
from pegbt.transport.streaming import Streamer

REPO = Path(__file__).resolve().parents[2]


def _until(condition, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.01)
    return condition()


@pytest.fixture
def endpoint() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


@pytest.fixture
def on_double(endpoint: str):
    """A robot double and the executive's robot connected to it (enabled and homed)."""
    double = CrtkDouble(endpoint)
    try:
        robot = connect_crtk_robot(endpoint)
        yield double, robot
        robot.close()
    finally:
        double.close()


class Sniffer:
    """A raw zenoh session that answers and listens on every key the executive must never touch."""

    FORBIDDEN = ("sim/**", "**/follow_jt", "**/trigger", "**/fiducial_js")

    def __init__(self, endpoint: str) -> None:
        config = zenoh.Config()
        config.insert_json5("mode", json.dumps("peer"))
        config.insert_json5("connect/endpoints", json.dumps([endpoint]))
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("scouting/gossip/enabled", "false")
        self.session = zenoh.open(config)
        self.seen: list[str] = []
        self.entities = []
        for key in self.FORBIDDEN:
            self.entities.append(
                self.session.declare_subscriber(key, lambda s: self.seen.append(str(s.key_expr)))
            )
            self.entities.append(
                self.session.declare_queryable(key, lambda q: self.seen.append(f"query {q.key_expr}"))
            )

    def close(self) -> None:
        self.session.close()


def test_a_run_enables_and_homes_the_arms_logs_what_the_robot_says_and_touches_no_simulator_key(
    endpoint: str, tmp_path: Path
) -> None:
    double = CrtkDouble(endpoint)
    sniffer = Sniffer(endpoint)
    tree = tmp_path / "look.yaml"
    tree.write_text("doc: one capture from the robot's camera\ntree:\n  capture: {}\n")
    out = io.StringIO()
    try:
        time.sleep(0.3)  # the sniffer's declarations reach the double's side
        output = run_tree_file(
            RunOptions(
                tree,
                tmp_path / "look.jsonl",
                {"interface": "dvrk", "endpoint": endpoint, "condition": "uncalibrated"},
                timeout=20,
            ),
            quiet=False,
            out=out,
        )
        assert output.result.outcome == "success"
        for arm in ("PSM1", "PSM2"):
            assert [r.message.string for r in double.commands(f"{arm}/state_command")] == ["enable", "home"]
            assert double.arms[arm].state == "ENABLED" and double.arms[arm].homed
        assert all(r.attachment is None for r in double.received)
        records = [json.loads(line) for line in (tmp_path / "look.jsonl").read_text().splitlines()]
        messages = [(r["source"], r["level"], r["text"]) for r in records if r["type"] == "message"]
        assert ("PSM1", "status", "PSM1: power on") in messages
        assert "STATUS   PSM2: power on" in out.getvalue()  # the arm's name once, though the robot gave it
        assert "PSM2: PSM2" not in out.getvalue()
        log = read_tick_log(tmp_path / "look.jsonl")  # the reader takes `message` records
        assert len(log.messages) == len(messages) and log.outcome == "success"
        assert "robot:    " in summary(log)
        time.sleep(0.3)
        assert sniffer.seen == []
    finally:
        sniffer.close()
        double.close()


def test_an_arm_already_enabled_and_homed_gets_no_state_command(endpoint: str) -> None:
    double = CrtkDouble(endpoint, enabled=True, homed=True)
    try:
        robot = connect_crtk_robot(endpoint)  # joins after the double published its (latched) state
        robot.close()
        assert double.commands("state_command") == []
    finally:
        double.close()


@pytest.fixture
def arms(endpoint: str):
    """PSM1 and PSM2 as `CrtkArm`s with their streamer, on a double that is DISABLED and will not home."""
    double = CrtkDouble(endpoint, homes=False, home_seconds=0.2)
    session = open_session(client_settings([endpoint]))
    settings = {arm: arm_settings(arm) for arm in ("PSM1", "PSM2")}
    streamer = Streamer([endpoint], "", settings, 0.01)
    wire = BridgeWire(session)
    clients = [CrtkArm(wire, arm, settings=settings[arm], streamer=streamer) for arm in settings]
    for client in clients:
        client.wait_until_ready(20.0)
    yield double, clients
    streamer.close()
    session.close()
    double.close()


def test_an_arm_that_will_not_home_stops_the_run_naming_the_arm_its_state_and_what_the_robot_said(
    arms,
) -> None:
    double, clients = arms
    started = time.monotonic()
    with pytest.raises(PegbtError) as caught:
        make_ready(clients, enable_timeout=30.0, home_timeout=1.5)
    # at the home deadline (with a loaded machine's margin), not at the enable deadline
    assert time.monotonic() - started < 1.5 + 10.0
    message = str(caught.value)
    assert message.startswith("PSM1: did not home within 1.5 s: it is ENABLED, not homed")
    assert "unable to reach home position" in message


def test_a_trajectory_is_streamed_as_servo_set_points_within_limits_and_a_goal_ends_by_crtk_rule(
    endpoint: str,
) -> None:
    double = CrtkDouble(endpoint)
    robot = connect_crtk_robot(endpoint)
    try:
        arm = robot.arm("PSM1")
        motion = ArmMotion(arm.settings)
        start = motion.start_from(arm)
        target = start + np.array([0.2, -0.1, 0.02, 0.3, 0.2, -0.2])
        trajectory = motion.through(start, [target], ["target"])
        handle = arm.move_jp(trajectory)
        assert handle.busy
        assert _until(lambda: not handle.busy, trajectory.duration + 20)
        assert handle.done, handle.error
        # the set-point publisher drops what a congested queue cannot take (KEEP_LAST, as the bridge): its
        # last row may never come on a loaded machine: the last received is then within two rows of the end
        # (that the final row is sent, exactly, test_streamer_resume shows, counting what was lost)
        q = trajectory.q
        _until(lambda: np.array_equal(double.arms["PSM1"].setpoint, q[-1]), 5)
        servo = double.commands("PSM1/servo_jp")
        sent = np.array([r.message.position for r in servo])
        assert len(sent) >= len(trajectory) // 2  # a loaded machine skips a late period rather than burst
        assert np.abs(sent[0] - q[0]).max() <= np.abs(q[2] - q[0]).max() + 1e-12
        assert np.abs(sent[-1] - q[-1]).max() <= np.abs(q[-1] - q[-3]).max() + 1e-12
        assert np.all(np.diff(sent[:, 0]) >= -1e-12)  # in order, along a monotone yaw
        assert double.arms["PSM1"].clips == 0 and np.array_equal(double.arms["PSM1"].setpoint, sent[-1])
        # the cadence by the streamer's own stamps, which a starved receiver cannot bunch up or spread out
        stamps = np.array([r.message.header.stamp.sec + r.message.header.stamp.nanosec * 1e-9 for r in servo])
        assert 0.005 < float(np.median(np.diff(stamps))) < 0.02  # about one every control period

        jaw = arm.jaw.move_jp(0.8)
        assert _until(lambda: not jaw.busy, 10) and jaw.done
        _until(lambda: double.arms["PSM1"].jaw == 0.8, 5)
        jaw_step = arm.settings.jaw_velocity * arm.settings.control_period  # the ramp's last row, if lost
        assert abs(double.arms["PSM1"].jaw - 0.8) <= jaw_step + 1e-12

        before = double.arms["PSM1"].setpoint.copy()
        goal = before + np.array([0.0, 0.0, -0.01, 0.0, 0.0, 0.0])
        move = arm.move_jp(goal)
        assert move.busy  # a not-busy state from before the command does not count
        assert _until(lambda: not move.busy, 10) and move.done
        assert np.allclose(double.arms["PSM1"].setpoint, goal)

        long = motion.through(goal, [goal + np.array([0.5, 0, 0, 0, 0, 0])], ["far"])
        motion.desired = goal
        stopped = arm.move_jp(long)
        time.sleep(0.2)
        stopped.stop()
        assert stopped.failed and "stopped by the client" in stopped.error
        assert _until(lambda: len(double.commands("PSM1/hold")) == 1)
        assert all(r.attachment is None for r in double.received)
    finally:
        robot.close()
        double.close()


def test_no_set_point_outside_the_limits_is_ever_sent(endpoint: str) -> None:
    double = CrtkDouble(endpoint)
    robot = connect_crtk_robot(endpoint)
    try:
        arm = robot.arm("PSM2")
        start = arm.setpoint_js.position
        t = np.arange(0.0, 1.0, 0.01)
        q = np.repeat(start[None], len(t), axis=0)
        q[:, 1] = np.linspace(start[1], 1.0, len(t))  # pitch to 57°: past the dVRK's 53°, slowly
        trajectory = type("Plan", (), {"t": t, "q": q})()
        with pytest.raises(CommandRefused, match="outside"):
            arm.move_jp(trajectory)
        # and the streamer itself, handed it directly, plays up to the limit and stops there
        handle = arm.stream("arm", t, q, "past the limit", float(t[-1]))
        assert _until(lambda: not handle.busy, 10) and handle.failed
        assert "set-point refused" in handle.error and "q2 (pitch)" in handle.error
        sent = np.array([r.message.position for r in double.commands("PSM2/servo_jp")])
        limits = arm.settings
        assert len(sent) > 10 and np.all(sent >= limits.lower) and np.all(sent <= limits.upper)
        assert np.all(sent >= LOWER) and np.all(sent <= UPPER) and double.arms["PSM2"].clips == 0
        assert _until(lambda: len(double.commands("PSM2/hold")) == 1)
    finally:
        robot.close()
        double.close()


def test_the_streamer_holds_the_arm_and_exits_when_its_executive_is_killed(endpoint: str) -> None:
    double = CrtkDouble(endpoint)
    script = textwrap.dedent(
        f"""
        import numpy as np
        from pegbt.behaviours.resources.arm_motion import ArmMotion
        from pegbt.behaviours.resources.robot import connect_crtk_robot
        robot = connect_crtk_robot("{endpoint}")
        arm = robot.arm("PSM1")
        motion = ArmMotion(arm.settings)
        start = motion.start_from(arm)
        handle = arm.move_jp(motion.through(start, [start + np.array([1.0, 0, 0, 0, 0, 0])], ["far"]))
        print(arm._streamer.process.pid, flush=True)
        import time; time.sleep(60)
        """
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(REPO / "tests")])}
    executive = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env)
    try:
        streamer_pid = int(executive.stdout.readline())
        assert _until(lambda: len(double.commands("PSM1/servo_jp")) > 5, 10)
        assert double.commands("PSM1/hold") == []
        executive.send_signal(signal.SIGKILL)
        executive.wait(timeout=5)

        def gone() -> bool:
            try:
                os.kill(streamer_pid, 0)
            except ProcessLookupError:
                return True
            with open(f"/proc/{streamer_pid}/stat") as stat:  # a zombie until init reaps it: exited
                return stat.read().split(")")[-1].split()[0] == "Z"

        assert _until(gone, 10)
        assert _until(lambda: len(double.commands("PSM1/hold")) == 1)  # it may still be on its way
        count = len(double.commands("PSM1/servo_jp"))
        time.sleep(0.2)
        assert len(double.commands("PSM1/servo_jp")) == count  # the stream stopped
    finally:
        if executive.poll() is None:
            executive.kill()
        double.close()


def test_a_capture_is_the_first_cloud_stamped_after_the_request_without_its_nan_points(endpoint: str) -> None:
    double = CrtkDouble(endpoint)
    robot = connect_crtk_robot(endpoint)
    try:
        handle = robot.camera.capture_async()
        cloud = handle.result(10.0)
        assert handle.stamp > handle.requested_at and isinstance(cloud, ColouredPoints)  # x, y, z and rgb
        assert cloud.points.shape == (180, 3) and np.isfinite(cloud.points).all()  # 20 of 200 were NaN
        assert cloud.rgba.shape == (180,)  # the colours of the points kept
    finally:
        robot.close()
        double.close()


def test_a_streaming_camera_is_given_the_liveness_to_answer_a_capture_and_2_s_at_least(endpoint: str) -> None:
    """A camera slower than 2 s to send the next cloud (a simulator's on a loaded machine) is given as long as
    the run's `--liveness` allows the robot to be silent."""
    double = CrtkDouble(endpoint, camera_period=3.0)
    patient, default = connect_crtk_robot(endpoint, liveness=5.0), connect_crtk_robot(endpoint)
    try:
        assert (patient.camera.timeout, default.camera.timeout) == (5.0, 2.0)
        patient.camera.capture_async().result(patient.camera.timeout)  # right after one cloud came
        handle = patient.camera.capture_async()
        handle.result(patient.camera.timeout)  # the next is 3 s away
        assert handle.stamp - handle.requested_at > 2.0
    finally:
        patient.close()
        default.close()
        double.close()


def test_the_streaming_cameras_clouds_reach_the_client_only_while_a_capture_waits(endpoint: str) -> None:
    double = CrtkDouble(endpoint)
    robot = connect_crtk_robot(endpoint)
    clouds = double._camera  # the double's publisher of the camera's clouds

    def matching() -> bool:
        return bool(clouds.matching_status.matching)

    try:
        time.sleep(0.5)  # a subscriber declared at connection would have reached the double by now
        assert not matching()
        for _ in range(2):  # and again once unsubscribed
            handle = robot.camera.capture_async()
            assert _until(matching)
            points = np.asarray(handle.result(10.0))
            assert handle.stamp > handle.requested_at and points.shape == (180, 3)
            assert _until(lambda: not matching())
    finally:
        robot.close()
        double.close()


def test_bad_dvrk_options_are_one_clear_line_each(pegbt_cli, tmp_path: Path) -> None:
    auto = pegbt_cli("run", "trees/unilateral.yaml", "--interface", "dvrk", "--log", tmp_path / "a.jsonl")
    assert auto.returncode == 2 and "give its bridge's address" in auto.stderr
    missing = pegbt_cli(
        "run",
        "trees/unilateral.yaml",
        "--interface",
        "dvrk",
        "--endpoint",
        f"tcp/127.0.0.1:{free_port()}",
        "--robot-config",
        tmp_path / "nowhere",
        "--log",
        tmp_path / "b.jsonl",
    )
    assert missing.returncode == 2 and "not a folder" in missing.stderr and "nowhere" in missing.stderr
    for run in (auto, missing):
        assert "Traceback" not in run.stderr and len(run.stderr.strip().splitlines()) == 1


def test_a_recording_of_a_crtk_run_holds_the_robots_topics_as_an_independent_reader_decodes_them(
    endpoint: str, tmp_path: Path
) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    double = CrtkDouble(endpoint)
    tree = tmp_path / "look.yaml"
    # the run goes on a second after its capture, so that the recording does not end with the camera's cloud
    # still on its way to the recorder's subscriber (the capture's cloud may reach the camera's first)
    tree.write_text(
        "doc: one capture from the robot's camera, then a second of the robot's topics\n"
        "tree: {sequence: [{capture: {}}, {wait: {seconds: 1.0}}]}\n"
    )
    try:
        output = run_tree_file(
            RunOptions(
                tree,
                tmp_path / "look.jsonl",
                {"interface": "dvrk", "endpoint": endpoint, "condition": "uncalibrated"},
                timeout=20,
                record=tmp_path / "look.mcap",
            )
        )
    finally:
        double.close()
    assert output.result.outcome == "success"
    with (tmp_path / "look.mcap").open("rb") as file:
        reader = make_reader(file, decoder_factories=[DecoderFactory()])
        seen: dict[str, list[object]] = {}
        for schema, channel, _, message in reader.iter_decoded_messages():
            seen.setdefault(channel.topic, []).append((schema.name, message))
    for arm in ("PSM1", "PSM2"):  # the robot's states as its topics carried them, with their ROS 2 types
        for topic in ("measured_js", "setpoint_js", "jaw/measured_js", "jaw/setpoint_js"):
            assert {name for name, _ in seen[f"/{arm}/{topic}"]} == {"sensor_msgs/msg/JointState"}
        assert seen[f"/{arm}/operating_state"][-1][1].state == "ENABLED"  # latched: there from the start
    clouds = seen["/camera/camera/depth/color/points"]
    assert clouds and clouds[0][0] == "sensor_msgs/msg/PointCloud2"
    assert "/pegbt/ticks" in seen


@pytest.mark.parametrize("offset", [-5.0, 5.0], ids=["robot clock behind", "robot clock ahead"])
def test_homing_and_a_goal_end_by_the_robots_own_clock_whatever_the_skew(
    endpoint: str, offset: float
) -> None:
    """The dVRK stamps `operating_state` with its own computer's clock (cisst-ros `mtsCISSTToROS.h`,
    `cisst_header_to_ros_header`), and pegbt runs on another computer: "stamped after the command" is
    judged on the robot's clock. Behind, a stamp never passes the local send time (homing and every goal
    would time out); ahead, the not-busy state from before the command would end a goal at once."""
    double = CrtkDouble(endpoint, clock_offset=offset, move_seconds=1.0)
    robot = connect_crtk_robot(endpoint)  # enables and homes: waits for a homed state stamped after `home`
    try:
        assert all(arm.homed for arm in double.arms.values())
        arm = robot.arm("PSM1")
        goal = double.arms["PSM1"].setpoint + np.array([0.0, 0.0, -0.01, 0.0, 0.0, 0.0])
        move = arm.move_jp(goal)
        assert move.busy  # the not-busy state from before the command does not count
        time.sleep(0.3)  # the robot has taken the command and is still moving (1 s)
        assert move.busy
        assert _until(lambda: not move.busy, 10) and move.done, move.error
        assert np.allclose(double.arms["PSM1"].setpoint, goal)
    finally:
        robot.close()
        double.close()


def test_a_goal_is_done_once_the_set_point_the_next_motion_plans_from_has_come(endpoint: str) -> None:
    """`operating_state` and `setpoint_js` are topics of their own: the not-busy state may come before the
    set-point at the goal. The next trajectory starts from the client's `setpoint_js`, so a goal counted
    done on the state alone had the next one refused for its first step (seen on a loaded machine)."""
    double = CrtkDouble(endpoint, setpoint_lag=0.3)
    robot = connect_crtk_robot(endpoint)
    try:
        arm = robot.arm("PSM1")
        goal = double.arms["PSM1"].setpoint + np.array([0.0, 0.0, -0.01, 0.0, 0.0, 0.0])
        move = arm.move_jp(goal)
        assert _until(lambda: not move.busy, 10) and move.done, move.error
        assert np.allclose(arm.setpoint_js.position, goal)
    finally:
        robot.close()
        double.close()


def test_no_bridge_at_the_address_is_one_line_naming_the_address_and_what_should_listen(
    short_connect_waits, capsys, tmp_path: Path
) -> None:
    address = f"tcp/127.0.0.1:{free_port()}"
    for ros2, listener in (("bridge", "zenoh-bridge-ros2dds"), ("rmw_zenoh", "rmw_zenohd")):
        log = tmp_path / f"{ros2}.jsonl"
        tree = str(REPO / "trees" / "unilateral.yaml")
        argv = ["run", tree, "--interface", "dvrk", "--ros2", ros2, "--endpoint", address]
        assert main([*argv, "--log", str(log)]) == 3
        stderr = capsys.readouterr().err
        assert f"nothing answers at {address}" in stderr and listener in stderr
        assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1


def test_a_robot_under_another_namespace_is_told_apart_from_no_robot(
    endpoint: str, short_connect_waits
) -> None:
    double = CrtkDouble(endpoint)  # its topics without a namespace, as a bridge started without one
    try:
        with pytest.raises(
            EndpointSilent, match=rf"{endpoint} answers, but no robot topic comes under namespace 'lab'"
        ):
            connect_crtk_robot(endpoint, namespace="lab")
    finally:
        double.close()


def test_joints_without_the_latched_operating_state_name_the_bridge_version_that_serves_it(
    endpoint: str, short_connect_waits
) -> None:
    """The dVRK sends `operating_state` only when it changes (cisst-ros `mtsROSBridge.h`, an event publisher,
    latched): a late joiner has it only from the bridge's cache of latched topics."""
    double = CrtkDouble(endpoint, latched=False)
    try:
        with pytest.raises(EndpointSilent, match=r"/PSM1/operating_state.*joints come.*1\.5\.1"):
            connect_crtk_robot(endpoint)
    finally:
        double.close()


def test_an_arm_disabled_from_elsewhere_mid_motion_stops_the_run_naming_its_state(on_double) -> None:
    """The dVRK takes `disable` from any client (its console, another node: `mtsIntuitiveResearchKitArm.cpp`
    `state_command`) and then drops every command (`ArmIsReady`): no motion or recovery can succeed."""
    double, robot = on_double
    arm = robot.arm("PSM1")
    start = arm.setpoint_js.position
    handle = arm.move_jp(ArmMotion(arm.settings).through(start, [start + [0.5, 0, 0, 0, 0, 0]], ["far"]))
    assert handle.busy
    double.console("PSM1", "disable")
    with pytest.raises(EndpointSilent, match="PSM1 is DISABLED"):
        _until(lambda: not handle.busy, 10)
    with pytest.raises(EndpointSilent, match="PSM1 is DISABLED"):
        arm.jaw.move_jp(0.5)  # nor may anything else be sent
    assert robot.arm("PSM2").measured_js is not None  # the other arm is still ready


def test_clouds_stamped_before_the_request_by_a_clock_behind_say_so(endpoint: str) -> None:
    """A camera's clouds are stamped by its computer's clock (realsense2_camera), which may lag this one's:
    a capture then never comes, and its error says the clouds did, stamped before the request."""
    double = CrtkDouble(endpoint, clock_offset=-5.0)
    robot = connect_crtk_robot(endpoint)
    try:
        with pytest.raises(
            EndpointSilent,
            match=r"stamped after the request within 1 s: \d+ came, stamped at least 5\.\d+ s before they arrived",
        ):
            robot.camera.capture_async().result(1.0)
    finally:
        robot.close()
        double.close()
