"""A real dVRK's first minutes, what is refused before anything moves: `--speed` below 1 on a robot without
the `trajectory_j` ratios (against the CRTK double, `crtk_double.py`) and `--robot-clock-offset` outside the
simulator's dVRK interface. What the robot does in real time is in `tests/system/test_dvrk_first_minutes.py`."""

from __future__ import annotations

import pytest
from crtk_double import CrtkDouble

from pegbt.behaviours.resources.robot import connect_crtk_robot
from pegbt.errors import PegbtError
from pegbt.sim.process import free_port


def test_speed_below_one_on_a_robot_without_trajectory_ratios_stops_before_anything_moves() -> None:
    """A dVRK 2.1 or 2.2 has no `trajectory_j` ratio: its homing would go at full speed, so `--speed 0.5`
    stops, naming the option, before any arm is enabled."""
    address = f"tcp/127.0.0.1:{free_port()}"
    double = CrtkDouble(address, ratios=False)
    try:
        with pytest.raises(PegbtError) as refused:
            connect_crtk_robot(address, liveness=5.0, speed=0.5)
        assert refused.value.field == "--speed" and "dVRK 2.3 or later" in refused.value.message
        assert not double.commands("state_command") and double.arms["PSM1"].state == "DISABLED"
    finally:
        double.close()


def test_a_robot_clock_offset_is_the_dvrk_interfaces_option(capsys: pytest.CaptureFixture[str]) -> None:
    from pegbt.cli import main

    assert main(["sim", "--robot-clock-offset", "5", "--no-world"]) == 2
    assert main(["eval", "--variant", "unilateral", "--trials", "1", "--robot-clock-offset", "5"]) == 2
    assert main(["sim", "--interface", "dvrk", "--robot-clock-offset", "nan", "--no-world"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and all("--robot-clock-offset" in line for line in lines), lines
