"""The simulator's dVRK interface as a node of a ROS 2 graph on rmw_zenoh, driven by zenoh-ros2-sdk
(ROBOTIS's rmw_zenoh client) as a ROS 2 operator's node would: it reads `/PSM1/measured_js`, enables and
homes the arm with `state_command`, and moves it with `servo_jp`. The router is a zenoh session in router mode
on 127.0.0.1. A whole pegbt trial over rmw_zenoh, with a Zivid, is in `test_realtime_trials.py`."""

from __future__ import annotations

from pathlib import Path

import pytest
from rmw_zenoh_helpers import lines, partner

from pegbt.sim.process import SimProcess
from pegbt.transport.codec import JOINT_STATE


@pytest.mark.slow
def test_a_ros2_node_reads_enables_homes_and_servos_the_simulated_arm(messages_dir, router) -> None:
    simulator = SimProcess(["--no-world"], interface="dvrk", router=f"tcp/127.0.0.1:{router}")
    try:
        info = lines(partner(messages_dir, router, "info", "/PSM1/measured_js", "/PSM1/servo_jp"))[-1]
        assert info["/PSM1/measured_js"]["types"] == [JOINT_STATE]
        assert [p[0] for p in info["/PSM1/measured_js"]["publishers"]] == ["pegbt_sim"]
        assert [s[0] for s in info["/PSM1/servo_jp"]["subscribers"]] == ["pegbt_sim"]
        listened = lines(partner(messages_dir, router, "sub", "/PSM1/measured_js", JOINT_STATE, "5", "20"))
        assert len(listened[-1]["messages"]) == 5
        drove = lines(partner(messages_dir, router, "drive", "PSM1", "0.05", "40"), timeout=60)[-1]
    finally:
        simulator.stop()
    states = drove["states"]
    assert any(s["state"] == "ENABLED" and not s["is_homed"] for s in states)
    assert any(s["state"] == "ENABLED" and s["is_homed"] for s in states)
    assert drove["after"] is not None
    assert drove["after"][0] - drove["before"][0] == pytest.approx(0.05, abs=0.01)


def _sims_stderr(*connects: str) -> list[str]:
    """What `pegbt sim --interface dvrk --ros2 rmw_zenoh --connect CONNECT` says on stderr, one simulator per
    CONNECT, all started at once: from the moment each says it serves, the simulator gives a router
    `CONNECT_GRACE` to answer before it says that nothing does; they are stopped 3 s after that."""
    import os
    import selectors
    import subprocess
    import sys
    import time

    from pegbt.sim.cli import CONNECT_GRACE

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    command = [sys.executable, "-m", "pegbt", "sim", "--interface", "dvrk", "--ros2", "rmw_zenoh"]
    command += ["--no-world", "--priority", "normal", "--connect"]
    simulators = [
        subprocess.Popen(
            [*command, connect], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
        )
        for connect in connects
    ]
    try:
        for simulator in simulators:
            assert simulator.stdout is not None
            with selectors.DefaultSelector() as selector:
                selector.register(simulator.stdout, selectors.EVENT_READ)
                assert selector.select(120), "the simulator did not start within 120 s"
            assert simulator.stdout.readline().startswith("pegbt sim: serving")
        time.sleep(CONNECT_GRACE + 3.0)
    finally:
        for simulator in simulators:
            simulator.terminate()
    return [simulator.communicate(timeout=20)[1] for simulator in simulators]


@pytest.mark.slow
def test_a_simulator_whose_router_is_absent_says_so_and_not_when_it_is_there(router) -> None:
    from pegbt.sim.process import free_port

    absent = f"tcp/127.0.0.1:{free_port()}"
    unanswered, answered = _sims_stderr(absent, f"tcp/127.0.0.1:{router}")
    assert f"nothing answers at {absent}" in unanswered
    assert "nothing answers" not in answered
