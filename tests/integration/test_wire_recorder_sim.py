"""`pegbt sim --record FILE.mcap`: the simulator records the commands it takes and the states it sends, read
back by the `mcap` library's readers, which know nothing of pegbt."""

from __future__ import annotations

import json

import numpy as np
import pytest
from bag_helpers import read_all


def test_the_simulator_records_the_commands_it_takes_and_the_state_it_sends(tmp_path):
    from pegbt.sim.process import SimProcess
    from pegbt.transport import ArmClient, SimClock, connect

    path = tmp_path / "sim.mcap"
    simulator = SimProcess(["--lockstep", "--no-world", "--record", str(path)])
    try:
        with connect([simulator.endpoint]) as link:
            clock = SimClock(link)
            arm = ArmClient(link, "PSM1", clock=clock)
            arm.wait_until_ready(30.0)
            goal = arm.measured_js.position + np.array([0.05, 0.0, 0.0, 0.0, 0.0, 0.0])
            handle = arm.move_jp(goal)
            for _ in range(100):
                clock.wait(0.05)
                if handle.done:
                    break
            assert handle.done
    finally:
        simulator.stop()
    messages = read_all(path)
    moves = [decoded for topic, _, _, decoded in messages if topic == "/PSM1/move_jp"]
    assert len(moves) == 1 and list(moves[0].position) == pytest.approx(list(goal))
    setpoints = [(t, decoded) for topic, _, t, decoded in messages if topic == "/PSM1/setpoint_js"]
    assert setpoints and list(setpoints[-1][1].position) == pytest.approx(list(goal), abs=1e-6)
    assert max(t for t, _ in setpoints) < 10e9  # simulated seconds since the simulator started
    events = [json.loads(decoded.data) for topic, _, _, decoded in messages if topic == "/pegbt/events"]
    assert events[0]["kind"] == "start" and events[0]["mode"] == "lockstep"
