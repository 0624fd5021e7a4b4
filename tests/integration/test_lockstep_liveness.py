"""In lockstep an arm's liveness counts from the simulator's last step reply, not from the wall clock of now:
a tick that computes long on a loaded machine (registration and a plan in one tick) is no silence of the
simulator, and must not stop the run, where a quiet machine's same trial goes on."""

from __future__ import annotations

import time
from types import SimpleNamespace

import pytest
from lockstep_helpers import lockstep_psm1

from pegbt.transport import EndpointSilent
from pegbt.transport import arm as arm_module

TICK = 0.02


@pytest.fixture(scope="module")
def arm():
    """A lockstep simulator of the arms alone, PSM1's client (its simulator liveness, 5 s) and its clock."""
    with lockstep_psm1() as stepped:
        yield stepped


def _later(monkeypatch: pytest.MonkeyPatch, seconds: float) -> None:
    """The arm client's monotonic clock `seconds` on: as if the tick had computed that long since."""
    real = time.monotonic
    monkeypatch.setattr(arm_module, "time", SimpleNamespace(monotonic=lambda: real() + seconds))


def test_a_long_tick_after_a_step_is_no_silence_of_a_lockstep_simulator(arm, monkeypatch):
    clock, psm1 = arm
    clock.wait(TICK)
    _later(monkeypatch, 3 * psm1.liveness_timeout)
    psm1.check_alive()
    assert psm1.is_alive and len(psm1.setpoint_js.position) == 6


def test_a_lockstep_arm_whose_state_stopped_coming_is_still_silent(arm, monkeypatch):
    clock, psm1 = arm
    clock.wait(TICK)
    clock.stepped_at = time.monotonic() + 3 * psm1.liveness_timeout  # a step whose state never came
    with pytest.raises(EndpointSilent, match="silent"):
        psm1.check_alive()
