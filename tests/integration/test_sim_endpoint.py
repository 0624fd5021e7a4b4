"""The simulator endpoint in its own process, driven over real zenoh sessions on loopback."""

from __future__ import annotations

import json
import threading
import time

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.physics import ArmPhysics
from pegbt.sim.process import SimProcess
from pegbt.transport import (
    ArmClient,
    CameraClient,
    CommandRefused,
    EndpointSilent,
    MotionStatus,
    SimClock,
    codec,
    connect,
)
from pegbt.transport.sequencing import Outlet

TICK = 0.01


@pytest.fixture(scope="module")
def lockstep():
    """One lockstep simulator of the arms alone with the dvrk-real cable physics, and a client link, clock and both arms."""
    with SimProcess(["--lockstep", "--physics", "dvrk-real", "--no-world"]) as sim:
        link = connect([sim.endpoint])
        clock = SimClock(link)
        arms = {name: ArmClient(link, name, clock=clock) for name in ("PSM1", "PSM2")}
        for arm in arms.values():
            arm.wait_until_ready(30.0)
        yield link, clock, arms
        link.close()


def finish(clock: SimClock, handle, limit: float = 5.0) -> MotionStatus:
    """Step the simulator until the motion is decided; then let encoders and cable lag settle."""
    end = clock.now() + limit
    while handle.busy and clock.now() < end:
        clock.wait(TICK)
    clock.wait(0.3)
    return handle.status


def test_client_moves_psm1_along_a_trajectory_and_reads_the_state_back(lockstep):
    _, clock, arms = lockstep
    psm1 = arms["PSM1"]
    start = psm1.setpoint_js.position
    goal = start + np.array([0.2, -0.1, 0.02, 0.3, 0.2, -0.2])
    t = np.arange(0, 1.0 + TICK / 2, TICK)
    blend = (1 - np.cos(np.pi * t / t[-1])) / 2
    trajectory = codec.TrajectoryPoints(t, start + np.outer(blend, goal - start))

    handle = psm1.move_jp(trajectory)
    assert handle.busy
    clock.wait(0.5)
    halfway = psm1.setpoint_js
    assert halfway.stamp == pytest.approx(clock.now(), abs=1e-6)
    assert np.allclose(halfway.position, trajectory.q[50], atol=1e-9)  # played back on its own timeline

    assert finish(clock, handle) is MotionStatus.DONE
    measured = psm1.measured_js
    assert measured.stamp == pytest.approx(clock.now(), abs=1e-6)
    assert np.allclose(measured.position, goal, atol=1e-5)
    assert np.allclose(psm1.setpoint_js.position, goal, atol=1e-12)


def test_goal_moves_of_arm_and_jaw_finish_within_planner_limits(lockstep):
    _, clock, arms = lockstep
    psm2 = arms["PSM2"]
    goal = np.array([-0.3, 0.2, 0.14, -0.5, 0.1, 0.2])
    move, grip = psm2.move_jp(goal), psm2.jaw.move_jp(0.6)
    positions = []
    while move.busy or grip.busy:
        clock.wait(TICK)
        positions.append(psm2.setpoint_js.position)
    assert move.done and grip.done
    speeds = np.abs(np.diff(positions, axis=0)) / TICK
    assert np.all(speeds <= psm2.settings.planner_velocity * (1 + 1e-6))
    assert np.allclose(positions[-1], goal) and psm2.jaw.setpoint_js.position[0] == pytest.approx(0.6)


def test_refused_commands_are_reported_and_never_applied(lockstep):
    link, clock, arms = lockstep
    psm1 = arms["PSM1"]
    before = psm1.setpoint_js.position

    with pytest.raises(CommandRefused, match="nan"):
        psm1.servo_jp(before + [0, 0, 0, 0, 0, np.nan])
    with pytest.raises(CommandRefused, match="insertion"):
        psm1.move_jp(before + [0, 0, 1.0, 0, 0, 0])
    with pytest.raises(CommandRefused, match="would move at"):
        psm1.servo_jp(before + [0.5, 0, 0, 0, 0, 0])

    # A client without guards: the endpoint itself refuses, says why on PSM1/error, and applies nothing.
    raw = Outlet(link.session, psm1.keys.servo_jp, link.source)
    tag = raw.put(codec.encode_joint_state(clock.now(), before + [0.3, 0, 0, 0, 0, 0]))
    clock.wait(TICK)
    outcome, reason = psm1.outcomes.of(tag.command_id(psm1.keys.servo_jp))
    assert outcome == "refused" and "would move at" in reason
    assert np.array_equal(psm1.setpoint_js.position, before)
    raw.close()

    # Refusals only the endpoint can know of reach the motion handle.
    psm1.state_command("disable")
    clock.wait(TICK)
    assert psm1.operating_state.state == "DISABLED"
    handle = psm1.move_jp(before + [0.1, 0, 0, 0, 0, 0])
    clock.wait(TICK)
    assert handle.status is MotionStatus.FAILED and "DISABLED" in handle.error
    psm1.state_command("enable")
    clock.wait(TICK)
    assert psm1.operating_state.state == "ENABLED"
    assert np.array_equal(psm1.setpoint_js.position, before)


def test_a_newer_command_aborts_the_running_motion_and_stop_holds(lockstep):
    _, clock, arms = lockstep
    psm1 = arms["PSM1"]
    start = psm1.setpoint_js.position
    first = psm1.move_jp(start + [0.4, 0, 0, 0, 0, 0])
    clock.wait(0.1)
    second = psm1.move_jp(start + [-0.2, 0, 0, 0, 0, 0])
    clock.wait(TICK)
    assert first.status is MotionStatus.FAILED and "aborted" in first.error
    assert second.busy
    second.stop()
    clock.wait(0.05)
    held = psm1.setpoint_js.position
    clock.wait(0.1)
    assert second.failed and np.array_equal(psm1.setpoint_js.position, held)


def test_dvrk_real_shows_backlash_and_q5_q6_coupling_in_fiducial_js(lockstep):
    _, clock, arms = lockstep
    psm2 = arms["PSM2"]
    wrist = [(0.8, 0.9), (0.4, -0.6), (0.1, -0.6), (-0.3, -0.6), (0.1, -0.6), (0.1, 0.8)]
    commands = np.array([[0.0, 0.0, 0.15, 0.0, q5, q6] for q5, q6 in wrist])

    def settle_at(q: np.ndarray) -> tuple[float, float]:
        assert finish(clock, psm2.move_jp(q)) is MotionStatus.DONE
        return psm2.measured_js.position[4], psm2.fiducial_js.position[4]

    settled = np.array([settle_at(q) for q in commands])
    assert np.allclose(settled[:, 0], commands[:, 4], atol=1e-6)  # the encoders never see the cables

    # The same set-points replayed through the preset (the first, large move takes up all play).
    path = np.concatenate([np.linspace(a, b, 60) for a, b in zip(commands[:-1], commands[1:])])
    expected = ArmPhysics.load("dvrk-real", "PSM2").simulate(path)[59::60, 4]
    assert np.allclose(settled[1:, 1], expected, atol=2e-3)

    from_above, from_below, q6_moved = settled[2, 1], settled[4, 1], settled[5, 1]
    assert from_above - from_below > 0.03  # hysteresis: same command, different physical q5
    assert abs(q6_moved - from_below) > 0.03  # coupling: only q6 moved, yet the physical q5 did too


def test_a_refused_step_is_reported_and_leaves_the_clock_usable(lockstep):
    link, _, _ = lockstep
    clock = SimClock(link)
    before = clock.now()
    with pytest.raises(
        PegbtError, match=r"simulator refused sim/step: steps: steps must be in 1\.\.1000000, got 2000000"
    ):
        clock.wait(20_000.0)  # two million control periods in one request
    assert clock.now() == before
    clock.wait(TICK)
    assert clock.now() == pytest.approx(before + TICK)


def test_clocks_stepping_at_once_are_served_in_turn(lockstep):
    """Two clocks of one client step from two threads: while one request waits at the barrier the other
    waits its turn, and both reach their targets (neither request is lost or holds the simulator up)."""
    link, _, _ = lockstep
    clocks = [SimClock(link, reply_timeout=30.0), SimClock(link, reply_timeout=30.0)]
    start = max(clock.now() for clock in clocks)
    failures: list[Exception] = []

    def step(clock: SimClock) -> None:
        try:
            for _ in range(150):
                clock.wait(TICK)
        except PegbtError as error:
            failures.append(error)

    threads = [threading.Thread(target=step, args=(clock,)) for clock in clocks]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not failures
    assert all(clock.now() >= start + 150 * TICK - 1e-6 for clock in clocks)


def test_capture_without_a_camera_fails_clearly(lockstep):
    link, _, _ = lockstep
    handle = CameraClient(link, timeout=0.2).capture_async()  # never waits, even with nobody listening
    assert not handle.sent and not handle.ready
    with pytest.raises(EndpointSilent, match="no camera listens"):
        handle.result(0.2)


def run_script(endpoint: str) -> list[tuple]:
    """A fixed client script: stream servo set-points, then a goal move; record what comes back each tick."""
    with connect([endpoint]) as link:
        clock = SimClock(link)
        psm1 = ArmClient(link, "PSM1", clock=clock)
        psm1.wait_until_ready(30.0)
        trace = []
        q = psm1.setpoint_js.position
        for _ in range(40):
            q = q + [0.004, 0, 0.0005, 0, 0.01, -0.01]
            psm1.servo_jp(q)
            clock.wait(TICK)
            trace.append((clock.now(), *psm1.measured_js.position, *psm1.fiducial_js.position))
        handle = psm1.move_jp(q - [0.2, 0, 0, 0, 0.3, 0])
        while handle.busy:
            clock.wait(TICK)
            trace.append((clock.now(), *psm1.measured_js.position, *psm1.setpoint_js.position))
        return trace


def test_lockstep_runs_are_deterministic_for_a_seed_with_faults(tmp_path):
    args = ["--lockstep", "--physics", "dvrk-real", "--loss", "0.2", "--latency", "0.02", "--seed", "3"]
    traces, logs = [], []
    for run in range(2):
        log = tmp_path / f"run{run}.jsonl"
        with SimProcess([*args, "--log", str(log)]) as sim:
            traces.append(run_script(sim.endpoint))
        logs.append([json.loads(line) for line in log.read_text().splitlines()])
    assert traces[0] == traces[1]
    faults = [
        [(e["time"], e["fault"], e["key"]) for e in entries if e["kind"] == "fault"] for entries in logs
    ]
    assert faults[0] == faults[1]
    assert {"loss", "latency"} <= {fault for _, fault, _ in faults[0]}


def test_real_time_endpoint_echoes_servo_and_a_killed_one_is_detected_in_time():
    with SimProcess(["--physics", "ideal", "--no-world"]) as sim, connect([sim.endpoint]) as link:
        psm1 = ArmClient(link, "PSM1")
        psm1.wait_until_ready(30.0)
        q = psm1.setpoint_js.position + [0.01, 0, 0, 0, 0, 0]
        psm1.servo_jp(q)
        deadline = time.monotonic() + 10.0
        while not np.array_equal(psm1.setpoint_js.position, q) and time.monotonic() < deadline:
            time.sleep(0.001)
        assert np.array_equal(psm1.setpoint_js.position, q)
        assert psm1.is_alive

        sim.kill()
        killed = time.monotonic()
        while True:
            try:
                psm1.measured_js
            except EndpointSilent as error:
                detected = time.monotonic() - killed
                assert "silent" in str(error)
                break
            time.sleep(0.005)
        assert detected <= 5 * psm1.liveness_timeout  # in time, with room for a busy machine's scheduling
        with pytest.raises(EndpointSilent):
            psm1.servo_jp(q)  # never sent into the void


def test_injected_crash_is_logged_and_ends_the_endpoint(tmp_path):
    log = tmp_path / "crash.jsonl"
    with SimProcess(["--lockstep", "--crash-at", "0.2", "--log", str(log)]) as sim:
        with connect([sim.endpoint]) as link:
            clock = SimClock(link, reply_timeout=2.0)
            with pytest.raises(PegbtError):
                clock.wait(0.5)
        assert sim.wait(timeout=10) == 3
    crash = [json.loads(line) for line in log.read_text().splitlines() if '"crash"' in line]
    assert crash == [{"time": 0.2, "kind": "fault", "fault": "crash"}]
