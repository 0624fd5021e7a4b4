"""The servo streamer resumes a trajectory after a stall instead of jumping to where it would be by now.

`Streamer.tick` is driven with explicit times against the CRTK robot double (raw zenoh and rosbags,
`crtk_double.py`), which decodes every `servo_jp` it receives. Times and the period are powers of two, so a
tick lands exactly on a row of the trajectory and the robot must receive that row unchanged. The set-point
publishers drop what a congested queue cannot take (a set-point stream: the next one replaces it; rmw_zenoh
does the same for a KEEP_LAST topic, `rmw_publisher_data.cpp`); on a loaded machine a set-point may be lost on
the way, so the rig counts what never arrived and the rows must reach the robot in order with no more missing
than were lost. The last test stalls the real streamer process with
SIGSTOP and follows the warning into the robot's tick-log messages.
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from crtk_double import START, CrtkDouble

from pegbt.behaviours.resources.robot import connect_crtk_robot
from pegbt.motion.limits import arm_settings
from pegbt.sim.process import free_port
from pegbt.transport.streamer import STALL_PERIODS, Frame, Streamer
from pegbt.transport.streaming import MOTION_MARGIN

PERIOD = 2.0**-7  # s: about 8 ms, exact in binary like every tick time below
ROWS = 60


def _until(condition, timeout: float = 10.0, poll: float = 0.01) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(poll)
    return condition()


class Rig:
    """An in-process `Streamer` for PSM1 on the robot double, its reports, and a tick clock of its own."""

    def __init__(self, period: float = PERIOD) -> None:
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.double = CrtkDouble(endpoint, enabled=True, homed=True)
        self.reports: list[Frame] = []
        config = {
            "period": period,
            "connect": [endpoint],
            "namespace": "",
            "arms": {"PSM1": arm_settings("PSM1")},
        }
        self.streamer = Streamer(config, self.reports.append)
        self.lost = 0  # set-points sent that never reached the double
        assert _until(lambda: all(axis.reference() is not None for axis in self.streamer.axes.values()))
        assert _until(self._hold_got_through)
        # far enough ahead of the monotonic clock that `play` never moves a start to "now"
        self.t0 = 2.0 ** math.ceil(math.log2(time.monotonic() + 600.0))

    def _hold_got_through(self) -> bool:
        """Whether the double's subscriptions have reached the streamer's session: a `hold` arrives."""
        self.streamer.hold("PSM1")
        return _until(lambda: bool(self.double.commands("PSM1/hold")), timeout=0.1)

    def play(self, motion_id: int, axis: str, q: np.ndarray, at_tick: int = 0) -> None:
        t = np.arange(len(q)) * PERIOD
        assert self.streamer.handle(("play", motion_id, "PSM1", axis, t, q), self.t0 + at_tick * PERIOD)

    def tick(self, ticks: range | list[int]) -> None:
        """Tick at each of `ticks` (in periods from `t0`); before the next, the double has what it sent or
        the rig counts it lost (these ticks take no time, so nothing queues behind them)."""
        axes = self.streamer.axes.values()
        for k in ticks:
            before, received = [axis.last for axis in axes], len(self._servo_commands())
            self.streamer.tick(self.t0 + k * PERIOD)
            expected = received + sum(axis.last is not last for axis, last in zip(axes, before))
            if not _until(lambda: len(self._servo_commands()) >= expected, timeout=2.0, poll=0.0005):
                self.lost += expected - len(self._servo_commands())

    def _servo_commands(self) -> list:
        return self.double.commands("servo_jp")

    def assert_received(self, topic: str, rows: np.ndarray) -> None:
        """Once all but the lost have come, each set-point the double received on `topic` is one of `rows`,
        unchanged, in order, and no more rows are missing than the rig counted lost."""
        wanted = len(rows) - self.lost
        assert _until(lambda: len(self.double.commands(topic)) >= wanted), len(self.double.commands(topic))
        time.sleep(0.05)  # nothing more arrives
        got = np.array([r.message.position for r in self.double.commands(topic)])
        matches = [np.flatnonzero((rows == row).all(axis=1)) for row in got]
        assert all(len(m) == 1 for m in matches), "a set-point that is no row of the trajectory"
        indices = np.concatenate(matches)
        assert np.all(np.diff(indices) > 0), f"rows out of order or repeated: {indices.tolist()}"
        assert len(rows) - len(got) <= self.lost, (
            f"rows {sorted(set(range(len(rows))) - set(indices))} skipped"
        )

    def close(self) -> None:
        self.streamer.close()
        self.double.close()


@pytest.fixture
def rig() -> Iterator[Rig]:
    rig = Rig()
    yield rig
    rig.close()


def _yaw_sway(rows: int = ROWS) -> np.ndarray:
    """From the double's set-point: a yaw that speeds up (each row a bigger step), so no two rows are alike."""
    q = np.repeat(START[None], rows, axis=0)
    q[:, 0] += 2e-4 * np.arange(rows) ** 2  # at most 0.024 rad a row: 3 rad/s, under the 3.14 rad/s limit
    return q


def test_without_a_stall_every_row_reaches_the_robot_unchanged_one_per_tick(rig: Rig) -> None:
    q = _yaw_sway()
    rig.play(1, "arm", q)
    rig.tick(range(ROWS))
    rig.assert_received("PSM1/servo_jp", q)
    assert rig.reports == [("started", 1), ("done", 1)]


def test_after_a_stall_the_motion_resumes_a_period_after_its_last_set_point(rig: Rig) -> None:
    q = _yaw_sway()
    rig.play(1, "arm", q)
    rig.tick(range(10))  # rows 0-9
    rig.tick(range(40, 40 + ROWS - 10))  # 30 periods later: rows 10 to the last
    rig.assert_received(
        "PSM1/servo_jp", q
    )  # row 10 one period's step beyond row 9, not where row 40 would be
    assert rig.reports[:2] == [("started", 1), ("stalled", 1, pytest.approx(30 * PERIOD))]
    assert rig.reports[2:] == [("done", 1)]


def test_a_stall_during_the_last_rows_still_sends_them_all_and_is_done_on_the_last(rig: Rig) -> None:
    q = _yaw_sway()
    rig.play(1, "arm", q)
    rig.tick(range(ROWS - 2))  # rows 0 to the third-to-last
    rig.tick([ROWS + 40])  # long past the trajectory's end: the row after, not the last
    assert rig.reports == [("started", 1), ("stalled", 1, pytest.approx(42 * PERIOD))]
    rig.tick([ROWS + 41])
    assert rig.reports[-1] == ("done", 1)
    rig.tick([ROWS + 42])  # nothing left to send
    rig.assert_received("PSM1/servo_jp", q)


def test_each_axis_resumes_from_its_own_last_set_point(rig: Rig) -> None:
    arm = _yaw_sway()
    jaw = 0.02 * np.arange(20.0)[:, None]  # 2.6 rad/s, under the jaw's 6 rad/s, from the double's 0
    rig.play(1, "arm", arm)
    rig.tick(range(5))
    rig.play(2, "jaw", jaw, at_tick=5)  # starts 5 rows behind the arm
    rig.tick(range(5, 12))  # arm rows 5-11, jaw rows 0-6
    rig.tick(range(40, 60))  # 28 periods late: arm rows 12-31, jaw rows 7-19 then none
    assert ("stalled", 1, pytest.approx(28 * PERIOD)) in rig.reports
    assert ("stalled", 2, pytest.approx(28 * PERIOD)) in rig.reports
    assert rig.reports[-1] == ("done", 2)
    rig.assert_received("PSM1/servo_jp", arm[:32])
    rig.assert_received("PSM1/jaw/servo_jp", jaw)


@pytest.fixture
def robot_double() -> Iterator[tuple[CrtkDouble, Any]]:
    """The CRTK robot double and pegbt's CRTK robot client on it (which starts the real streamer)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    double = CrtkDouble(endpoint, enabled=True, homed=True)
    robot = connect_crtk_robot(endpoint)
    try:
        yield double, robot
    finally:
        robot.close()
        double.close()


def _stream_and_stop(double: CrtkDouble, arm: Any, t: np.ndarray, q: np.ndarray, seconds: float) -> Any:
    """Stream `q` at `t` on `arm`'s joints and, a few set-points in, stop the streamer's process for
    `seconds` (SIGSTOP: it is not scheduled); the motion's handle."""
    handle = arm.stream("arm", t, q, "sway", float(t[-1]))
    pid = arm._streamer.process.pid
    assert _until(lambda: len(double.commands("PSM1/servo_jp")) >= 10)
    os.kill(pid, signal.SIGSTOP)
    try:
        time.sleep(seconds)
    finally:
        os.kill(pid, signal.SIGCONT)
    return handle


def test_a_stalled_streamer_process_resumes_and_the_run_logs_a_warning(robot_double) -> None:
    double, robot = robot_double
    arm = robot.arm("PSM1")
    period = arm.settings.control_period
    t = np.arange(0.0, 1.0, period)
    q = np.repeat(START[None], len(t), axis=0)
    q[:, 0] += 0.4 * np.sin(np.pi * t / 2.0)  # about 0.006 rad a period, ending at 0.4 rad
    robot.log_messages()
    handle = _stream_and_stop(double, arm, t, q, 0.4)
    assert _until(lambda: not handle.busy, 30) and handle.done, handle.error
    _until(lambda: np.array_equal(double.commands("PSM1/servo_jp")[-1].message.position, q[-1]), 5)
    sent = np.array([r.message.position for r in double.commands("PSM1/servo_jp")])
    largest_row_step = np.abs(np.diff(q[:, 0])).max()
    # a gap short of a stall steps up to STALL_PERIODS periods, and a set-point lost on the way (the
    # publisher drops under load) one more; the stall none further (skipping it would be 0.07 rad or more)
    assert np.abs(np.diff(sent[:, 0])).max() <= (STALL_PERIODS + 1) * largest_row_step + 1e-9
    # the last row, or, lost on the way, a row before it
    assert np.abs(sent[-1] - q[-1]).max() <= np.abs(q[-1] - q[-3]).max()
    stalls = [m for m in robot.log_messages() if m["source"] == "streamer"]
    assert stalls and all(m["level"] == "warning" and m["text"].startswith("PSM1 arm: ") for m in stalls)
    seconds = [float(m["text"].split("no set-point for ")[1].split(" s")[0]) for m in stalls]
    assert max(seconds) >= 0.3


@pytest.mark.slow
def test_a_stall_longer_than_the_margin_extends_the_motions_bound_by_the_stall(robot_double) -> None:
    double, robot = robot_double
    arm = robot.arm("PSM1")
    t = np.arange(0.0, 0.5, arm.settings.control_period)
    q = np.repeat(START[None], len(t), axis=0)
    q[:, 0] += 0.1 * np.sin(np.pi * t)
    streamer = arm._streamer
    stall = 0.5 + max(MOTION_MARGIN, 2 * arm.liveness_timeout) + 1.0  # past the motion's bound
    handle = _stream_and_stop(double, arm, t, q, stall)
    assert stall > handle.bound
    assert _until(lambda: streamer.stalled(handle.motion_id) >= stall - 0.1)
    assert _until(lambda: not handle.busy, 30) and handle.done, handle.error
    assert handle.paused == streamer.stalled(handle.motion_id)


def test_a_motion_that_arrives_while_nothing_streams_starts_at_once_not_at_the_next_tick(rig: Rig) -> None:
    """The grid of ticks starts with a motion that finds the streamer idle; while another motion streams,
    the new one joins the grid (no axis gets two set-points within a period)."""
    q = _yaw_sway()
    t = np.arange(len(q)) * PERIOD
    now, next_tick = rig.t0 + 0.25 * PERIOD, rig.t0 + PERIOD
    assert rig.streamer.next_tick_for(("play", 1, "PSM1", "arm", t, q), next_tick, now) == now
    assert rig.streamer.next_tick_for(("stop", 1), next_tick, now) == next_tick
    rig.play(1, "arm", q)
    jaw = 0.02 * np.arange(20.0)[:, None]
    play_jaw = ("play", 2, "PSM1", "jaw", np.arange(20) * PERIOD, jaw)
    assert rig.streamer.next_tick_for(play_jaw, next_tick, now) == next_tick


def test_a_motion_given_a_tick_just_past_stays_on_the_grid_and_ends_on_its_last_rows_tick(rig: Rig) -> None:
    """Started at the time the loop read (a moment ago) rather than the clock's now, so its rows fall on
    the ticks: its last row was otherwise a moment after its tick, and sent a period later."""
    q = _yaw_sway(20)
    t = np.arange(len(q)) * PERIOD
    start = time.monotonic() - PERIOD / 4
    assert rig.streamer.handle(("play", 1, "PSM1", "arm", t, q), start)
    for k in range(len(q)):
        rig.streamer.tick(start + k * PERIOD)
    assert rig.reports[-1] == ("done", 1)


def test_the_last_row_goes_on_its_tick_when_the_ticks_are_a_running_sum_of_a_decimal_period() -> None:
    """The loop's ticks add a period at a time (`main`); at 0.01 s that sum falls short of a row's time by
    a few ulps, and every motion's last row, sent a period late, held its end back by 10 ms."""
    period = 0.01
    rig = Rig(period)
    try:
        q = _yaw_sway(20)
        start = time.monotonic()
        assert rig.streamer.handle(("play", 1, "PSM1", "arm", np.arange(len(q)) * period, q), start)
        tick = start
        for _ in range(len(q)):
            rig.streamer.tick(tick)
            tick += period
        assert rig.reports[-1] == ("done", 1)
    finally:
        rig.close()
