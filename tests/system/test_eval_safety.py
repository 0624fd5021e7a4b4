"""A campaign counts, per trial, the commands the simulator clipped to the dVRK's limits and the FAULTs its
arms entered, from the simulator's own log (`--interface dvrk`), and keeps that log when either happened."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from dvrk_peer import DvrkPeer, joint_state, wait_for
from trial_helpers import short_task

from pegbt.evaluation.campaign import Cell
from pegbt.evaluation.summary import summarise
from pegbt.evaluation.trial import TrialSpec, run_trial, truth_path
from pegbt.sim.process import SimProcess

OPERATING_STATE = "crtk_msgs/msg/OperatingState"
JOINT_STATE = "sensor_msgs/msg/JointState"


class _PeerOnceHomed(SimProcess):
    """The trial's simulator, and a peer that acts (`act`) once the trial has enabled and homed `ARM`."""

    ARM = "PSM1"
    sent: threading.Event

    def __enter__(self) -> SimProcess:
        threading.Thread(target=self._inject, daemon=True).start()
        return self

    def _inject(self) -> None:
        peer = DvrkPeer(self.endpoint)
        try:
            states = peer.subscribe_latched(f"{self.ARM}/operating_state")

            def ready() -> bool:
                decoded = states.decoded(OPERATING_STATE)
                return bool(decoded) and decoded[-1].state == "ENABLED" and decoded[-1].is_homed

            if wait_for(ready, timeout=120) and self.act(peer):
                self.sent.set()
        finally:
            peer.close()

    def act(self, peer: DvrkPeer) -> bool:
        raise NotImplementedError


class _OutOfLimitJaw(_PeerOnceHomed):
    """Once PSM2 is homed, a jaw angle beyond the tool's limit (`jaw/move_jp` 3 rad): the dVRK clips it
    (PSM.cpp `clip_jaw_jp`)."""

    ARM = "PSM2"
    sent = threading.Event()

    def act(self, peer: DvrkPeer) -> bool:
        peer.put("PSM2/jaw/move_jp", joint_state([3.0]))
        return True


@pytest.mark.slow
def test_a_clip_forced_during_a_real_time_trial_is_counted_and_its_logs_kept(tmp_path: Path, monkeypatch):
    monkeypatch.setattr("pegbt.evaluation.trial.SimProcess", _OutOfLimitJaw)
    spec = TrialSpec(
        "unilateral",
        "optimized",
        3,
        tmp_path / "clip.jsonl",
        tree=short_task(tmp_path),
        realtime=True,
        interface="dvrk",
    )
    record = run_trial(spec)
    assert _OutOfLimitJaw.sent.is_set()
    assert record.commands_clipped >= 1 and record.arm_faults == 0, record.error
    assert record.log == str(spec.log) and truth_path(spec.log).exists()  # kept to be looked at
    cell = Cell("unilateral", "optimized", 1, seed=3, realtime=True, interface="dvrk")
    figures = summarise(cell, [record])
    assert figures["commands_clipped"] == record.commands_clipped
    assert figures["commands_clipped_per_trial"] == [record.commands_clipped]
    assert figures["arm_faults"] == 0


class _TrackingErrorJump(_PeerOnceHomed):
    """Once PSM1 is homed and has begun to move, `servo_jp` 0.6 rad away in yaw: beyond the actuator's tracking
    tolerance, so the arm FAULTs (sawControllers `mtsPID.cpp`) and stays there until a person disables and
    enables it."""

    sent = threading.Event()

    def act(self, peer: DvrkPeer) -> bool:
        measured = peer.subscribe("PSM1/measured_js")
        if not wait_for(lambda: measured.all(), timeout=10):
            return False
        time.sleep(1.0)
        q = list(measured.decoded(JOINT_STATE)[-1].position)
        q[0] += -0.6 if q[0] > 0 else 0.6
        for _ in range(50):  # for 0.1 s, so that no set-point the streamer sends meanwhile undoes it
            peer.put("PSM1/servo_jp", joint_state(q))
            time.sleep(0.002)
        return True


@pytest.mark.slow
def test_an_arm_the_robot_faults_stops_the_run_at_once_naming_the_arm_and_what_the_robot_said(
    tmp_path: Path, monkeypatch
):
    monkeypatch.setattr("pegbt.evaluation.trial.SimProcess", _TrackingErrorJump)
    spec = TrialSpec(
        "unilateral",
        "optimized",
        4,
        tmp_path / "fault.jsonl",
        tree=short_task(tmp_path),
        realtime=True,
        interface="dvrk",
    )
    started = time.monotonic()
    record = run_trial(spec)
    assert _TrackingErrorJump.sent.is_set()
    assert record.outcome == "error" and record.arm_faults == 1, (
        record.arm_faults,
        record.run_wall_s,
        record.trial_time_s,
    )
    assert "PSM1 is in FAULT" in record.error and "tracking error" in record.error, record.error
    assert (
        time.monotonic() - started < 90
    )  # stopped, not retried against the FAULTed arm until the trial timeout
