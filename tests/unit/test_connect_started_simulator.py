"""The simulator a run starts itself is waited for as long as a lockstep step is: on a loaded machine it may
say it serves and then be starved of the CPU for longer than a robot is given to send its first state."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from pegbt.behaviours.resources import robot as robot_module

STARVED_S = robot_module.READY_TIMEOUT + 1.5
WAIT_UNTIL_READY = robot_module.Robot.wait_until_ready


def starve_then_wait(robot: robot_module.Robot, *args: float) -> None:
    """Stop the simulator (SIGSTOP) as the run starts waiting for its arms' first state; resume it
    `STARVED_S` s later."""
    assert robot.simulator is not None
    pid = robot.simulator.process.pid
    os.kill(pid, signal.SIGSTOP)
    threading.Timer(STARVED_S, resume, (pid,)).start()
    WAIT_UNTIL_READY(robot, *args)


def resume(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGCONT)
    except ProcessLookupError:
        pass  # the run gave up on it and stopped it


def test_a_run_waits_for_the_simulator_it_started_past_a_robots_ready_timeout(
    monkeypatch: pytest.MonkeyPatch,
):
    monkeypatch.setattr(robot_module.Robot, "wait_until_ready", starve_then_wait)
    started = time.monotonic()
    robot = robot_module.connect_robot("auto", seed=3)
    try:
        assert time.monotonic() - started > STARVED_S  # it was silent for longer than READY_TIMEOUT
        assert robot.simulator is not None and robot.lockstep
        assert {name: arm.measured_js.position.shape for name, arm in robot.arms.items()} == {
            "PSM1": (6,),
            "PSM2": (6,),
        }
    finally:
        robot.close()
