"""`pegbt run --speed F` (and `pegbt eval --speed F`): a first run on a robot goes slowly. Velocities scale by
F and accelerations by F², so every planned motion keeps its path and takes 1 / F as long."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.behaviours.resources.skills import Skills
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.motion.waypoints import transfer_waypoints
from pegbt.workcell import workcell

CELL = workcell()


def _waypoints():
    tops = CELL.peg_tops_in("PSM1")
    return transfer_waypoints(tops[0], tops[3], up=CELL.up_in("PSM1"))


@pytest.mark.parametrize("fraction", [0.25, 0.5])
@pytest.mark.parametrize("condition", ["uncalibrated", "optimized"])
def test_every_planned_motion_takes_one_over_the_fraction_as_long_on_the_same_path(
    condition: str, fraction: float
) -> None:
    full, slow = Skills(condition), Skills(condition, speed=fraction)
    fast_arm, slow_arm = full.arm("PSM1"), slow.arm("PSM1")
    period = fast_arm.settings.control_period
    start = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
    goal = start + [0.4, -0.3, 0.05, 0.6, 0.3, -0.2]
    plans = [
        (fast_arm.through(start, [goal], ["goal"]), slow_arm.through(start, [goal], ["goal"])),
        (fast_arm.transfer(_waypoints()), slow_arm.transfer(_waypoints())),
    ]
    for fast, slow_plan in plans:
        duration, slow_duration = fast.t[-1] - fast.t[0], slow_plan.t[-1] - slow_plan.t[0]
        assert slow_duration == pytest.approx(duration / fraction, abs=2 * period / fraction)
        assert np.allclose(slow_plan.q[-1], fast.q[-1], atol=1e-6)
        # the same path: the slow plan at time t is where the fast one was at t * fraction
        index = np.minimum(np.round(np.arange(len(fast.t)) / fraction).astype(int), len(slow_plan.t) - 1)
        assert np.max(np.abs(slow_plan.q[index] - fast.q)) < 0.02
        assert np.all(np.abs(slow_plan.qd).max(axis=0) <= slow_arm.settings.planner_velocity * 1.001)
    assert slow_arm.settings.jaw_velocity == pytest.approx(fast_arm.settings.jaw_velocity * fraction)


@pytest.mark.parametrize("bad", ["0", "1.5", "-0.25", "nan"])
def test_a_speed_outside_zero_to_one_is_one_clear_line(bad: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(PegbtError, match="--speed"):
        Skills("uncalibrated", speed=float(bad))
    assert main(["eval", "--variant", "unilateral", "--trials", "1", "--speed", bad]) == 2
    err = capsys.readouterr().err
    assert "--speed" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
