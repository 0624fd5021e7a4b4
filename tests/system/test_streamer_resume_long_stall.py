"""A stall of the servo streamer process longer than a motion's margin extends the motion's time bound by the
stall: SIGSTOP on the real streamer, against the CRTK robot double (`crtk_double.py`)."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from crtk_double import START, CrtkDouble
from pegbt.behaviours.resources.robot import connect_crtk_robot
from pegbt.sim.process import free_port
from pegbt.transport.streaming import MOTION_MARGIN


def _until(condition, timeout: float = 10.0, poll: float = 0.01) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(poll)
    return condition()


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
