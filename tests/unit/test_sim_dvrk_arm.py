"""The simulated dVRK PSM's controller, tick by tick without transport: what the dVRK's sources say it does
(sawIntuitiveResearchKit `mtsIntuitiveResearchKitArm.cpp`, `mtsIntuitiveResearchKitPSM.cpp`; figures
cited in `pegbt/sim/dvrk_config.py`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.sim import dvrk_config as dvrk
from pegbt.sim.dvrk_arm import DvrkArm

START = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)


class Ticking:
    """A `DvrkArm` and its clock, advanced a control period at a time."""

    def __init__(self) -> None:
        self.arm = DvrkArm("PSM1", arm_settings("PSM1"), ArmPhysics.load("ideal", "PSM1"), q0=START)
        self.now = 0.0

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / self.arm.period)):
            self.now += self.arm.period
            self.arm.advance(self.now)

    def until(self, condition, seconds: float = 10.0) -> float:  # type: ignore[no-untyped-def]
        """Seconds until `condition()` holds (fails past `seconds`)."""
        start = self.now
        while not condition():
            assert self.now - start < seconds, "condition never held"
            self.run(self.arm.period)
        return self.now - start

    def texts(self, topic: str) -> list[str]:
        return [report.text for report in self.arm.reports if report.topic == topic]


@pytest.fixture
def homed() -> Ticking:
    ticking = Ticking()
    ticking.arm.state_command("home")  # from DISABLED: powers, biases, homes (prmOperatingState.cpp)
    ticking.until(lambda: ticking.arm.is_homed and not ticking.arm.is_busy)
    ticking.arm.reports.clear()
    ticking.arm.safety.clear()
    return ticking


def test_home_from_disabled_powers_biases_homes_and_engages_in_the_dvrk_order() -> None:
    ticking = Ticking()
    ticking.arm.state_command("home")
    took = ticking.until(lambda: ticking.arm.is_homed)
    assert took >= dvrk.POWER_ON_TIME + dvrk.ENCODER_BIAS_TIME
    current = [
        text.removeprefix("PSM1: current state ") for text in ticking.texts("status") if "current" in text
    ]
    assert current == [
        "POWERING",
        "ENABLED",
        "CALIBRATING_ENCODERS_FROM_POTS",
        "ENCODERS_BIASED",
        "HOMING",
        "HOMED",
        "ENGAGING_ADAPTER",
        "HOMED",
        "ENGAGING_TOOL",
        "TOOL_ENGAGED",
        "HOMED",
    ]
    assert np.allclose(ticking.arm.setpoint[:6], START)  # a PSM holding a tool homes where it stands


def test_a_move_takes_the_dvrk_profile_time_within_its_velocity(homed: Ticking) -> None:
    homed.arm.move_jp([0.5, 0.0, 0.12, 0.0, 0.0, 0.0])
    positions = []
    while homed.arm.is_busy:
        homed.run(homed.arm.period)
        positions.append(homed.arm.setpoint[0])
    took = len(positions) * homed.arm.period
    # rest to rest at 90 deg/s^2 never reaching 90 deg/s: 2 sqrt(d / a) (mtsIntuitiveResearchKitPSM.cpp Init)
    assert took == pytest.approx(2 * math.sqrt(0.5 / math.radians(90)), abs=2 * homed.arm.period)
    assert np.max(np.abs(np.diff(positions))) <= math.radians(90) * homed.arm.period + 1e-9
    assert positions[-1] == pytest.approx(0.5)


def test_servo_during_a_move_ends_the_move_where_it_is(homed: Ticking) -> None:
    homed.arm.move_jp([1.0, 0.0, 0.12, 0.0, 0.0, 0.0])
    homed.run(0.5)
    here = homed.arm.setpoint[:6].copy()
    homed.arm.servo_jp(here)
    assert not homed.arm.is_busy
    homed.run(0.3)
    assert np.allclose(homed.arm.setpoint[:6], here)


def test_the_jaw_is_clipped_to_the_narrower_of_the_dvrk_and_pegbt_limits(homed: Ticking) -> None:
    homed.arm.jaw_servo_jp([-0.5])  # the tool file allows -40 deg, skills/psm.yaml -20 deg
    assert homed.arm.setpoint[6] == pytest.approx(max(arm_settings("PSM1").jaw_lower, dvrk.JAW_LOWER))
    (clip,) = homed.arm.safety
    assert (clip.event, clip.command, clip.details["joints"]) == ("clip", "jaw/servo_jp", ["jaw"])


def test_pause_drops_commands_and_resume_returns_to_where_it_was(homed: Ticking) -> None:
    homed.arm.state_command("pause")
    assert homed.arm.state == "PAUSED"
    homed.arm.servo_jp([0.05, 0.0, 0.12, 0.0, 0.0, 0.0])
    assert homed.texts("warning") == ["PSM1: servo_jp, arm not ready"]
    homed.arm.state_command("home")  # not valid while PAUSED
    assert homed.texts("warning")[-1] == 'PSM1: command "home" is not supported in state "PAUSED" (PAUSED)'
    homed.arm.state_command("resume")
    assert (homed.arm.state, homed.arm.current, homed.arm.is_homed) == ("ENABLED", "HOMED", True)
    homed.arm.servo_jp([0.05, 0.0, 0.12, 0.0, 0.0, 0.0])
    assert homed.arm.setpoint[0] == pytest.approx(0.05)


def test_not_ready_warnings_are_throttled_and_count_the_drops() -> None:
    ticking = Ticking()
    for _ in range(5):
        ticking.arm.move_jp([0.1, 0.0, 0.12, 0.0, 0.0, 0.0])
        ticking.run(0.6)
    # one at once, the next over 2 s later, counting the drops before it (mtsIntuitiveResearchKitArm.cpp ArmIsReady)
    assert ticking.texts("warning") == [
        "PSM1: move_jp, arm not ready",
        "PSM1: move_jp, arm not ready (4 errors)",
    ]


def test_an_enabled_arm_whose_encoders_are_not_biased_takes_no_jaw_command() -> None:
    ticking = Ticking()
    ticking.arm.state_command("enable")
    ticking.until(lambda: ticking.arm.state == "ENABLED" and not ticking.arm.is_busy)
    ticking.arm.jaw_servo_jp([0.5])
    assert ticking.texts("warning") == ["PSM1: jaw_servo_jp, arm not ready"]
    assert ticking.arm.setpoint[6] == 0.0


def test_a_grasp_squeezing_a_block_is_within_the_jaw_actuators_tolerance() -> None:
    """A jaw commanded to pegbt's closed angle but held open by a 2 mm wall (0.21 rad) is no tracking error:
    the jaw's error splits over two actuators through the tool's coupling."""
    errors = dvrk.actuator_errors(np.array([0, 0, 0, 0, 0, 0, arm_settings("PSM1").jaw_lower - 0.21]))
    assert np.all(np.abs(errors) < dvrk.ACTUATOR_TOLERANCE)


def test_a_jump_while_the_simulator_excuses_its_own_lateness_is_not_faulted_and_after_it_is(
    homed: Ticking,
) -> None:
    homed.arm.excuse_tracking(homed.now + 0.1)
    homed.arm.servo_jp([0.0, 0.0, 0.18, 0.0, 0.0, 0.0])  # insertion 6 cm at once: beyond its 5 cm tolerance
    homed.run(0.1)
    assert homed.arm.current != "FAULT" and homed.arm.safety == []
    assert homed.arm.measured[2] == pytest.approx(0.18, abs=1e-4)  # settled on it meanwhile
    homed.arm.servo_jp([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])  # the same jump back, the grace over
    homed.run(homed.arm.period)
    assert homed.arm.current == "FAULT"
    assert [event.event for event in homed.arm.safety] == ["tracking_error"]


def test_a_move_while_busy_republishes_busy(homed: Ticking) -> None:
    """mtsIntuitiveResearchKitArm.cpp `move_jp` → `control_move_jp_on_start` → `UpdateIsBusy(true)`: every
    move publishes the operating state, busy already or not."""
    homed.arm.move_jp([0.2, 0.0, 0.12, 0.0, 0.0, 0.0])
    homed.run(0.1)
    assert homed.arm.is_busy
    homed.arm.state_events.clear()
    homed.arm.move_jp([0.3, 0.0, 0.12, 0.0, 0.0, 0.0])
    assert [(event.state, event.is_busy) for event in homed.arm.state_events] == [("ENABLED", True)]


def test_after_a_fault_the_unpowered_arm_is_not_held(homed: Ticking) -> None:
    """mtsIntuitiveResearchKitArm.cpp `EnterFault` powers the arm off, and a PSM has no brakes: whatever moves
    it (a person, gravity) is not resisted."""
    homed.arm.servo_jp([0.0, 0.0, 0.18, 0.0, 0.0, 0.0])  # insertion 6 cm at once: a tracking error
    homed.run(homed.arm.period)
    assert homed.arm.current == "FAULT" and homed.arm.state == "FAULT"
    homed.run(0.2)
    homed.arm.sim.joints.encoder[0] += 0.05  # somebody pushes the yaw
    homed.run(0.5)
    assert homed.arm.measured[0] == pytest.approx(0.05, abs=1e-3)  # it stays where it was pushed
    assert homed.arm.setpoint[0] == pytest.approx(homed.arm.measured[0])


def test_the_clutch_makes_a_ready_arm_manual_busy_and_its_release_holds_where_it_was_left(
    homed: Ticking,
) -> None:
    """mtsIntuitiveResearchKitPSM.cpp `EventHandlerManipClutch`, `EnterManual`, `RunManual`, `LeaveManual`."""
    homed.arm.state_events.clear()
    homed.arm.clutch(True)
    assert (homed.arm.current, homed.arm.state, homed.arm.is_homed, homed.arm.is_busy) == (
        "MANUAL",
        "ENABLED",
        True,
        True,
    )
    homed.run(0.1)
    homed.arm.sim.joints.encoder[1] += 0.1  # the person moves the arm: nothing resists
    homed.run(0.3)
    assert homed.arm.measured[1] == pytest.approx(0.1, abs=1e-3)
    homed.arm.servo_jp([0.0, 0.15, 0.12, 0.0, 0.0, 0.0])  # executed, as on the robot
    homed.run(0.3)
    assert homed.arm.measured[1] == pytest.approx(0.15, abs=1e-3) and homed.arm.current == "MANUAL"
    homed.arm.clutch(False)
    assert (homed.arm.current, homed.arm.is_busy) == ("HOMED", False)
    homed.run(0.3)
    assert homed.arm.setpoint[1] == pytest.approx(0.15, abs=1e-3)  # held where it was left
    assert [(event.state, event.is_busy) for event in homed.arm.state_events][:1] == [("ENABLED", True)]
    disabled = Ticking()
    disabled.arm.clutch(True)
    assert disabled.arm.current == "DISABLED"
    assert disabled.texts("warning") == ["PSM1: arm not ready yet, manipulator clutch ignored"]
