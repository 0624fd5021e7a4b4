"""The monitor's 3D world on a simulated trial: its samples agree with the simulator's ground truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pegbt.executive.logfile import read_tick_log
from pegbt.executive.logplot import transfers

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_world_samples_of_a_simulated_trial_agree_with_the_simulators_truth(tmp_path):
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file
    from pegbt.monitor.live import LiveMonitor
    from pegbt.monitor.server import MonitorServer
    from pegbt.monitor.world import read_world_log, world_log_path
    from pegbt.sim.process import free_port

    log = tmp_path / "trial.jsonl"
    server = MonitorServer(free_port()).start()
    monitor = LiveMonitor(server, log)
    try:
        output = run_tree_file(
            RunOptions(
                REPO / "trees" / "unilateral.yaml",
                log,
                {"endpoint": "auto", "condition": "optimized", "seed": 1000},
            ),
            watch=monitor.watch,
        )
    finally:
        monitor.stop()
    judged = output.reports["robot"]
    parsed = read_tick_log(log)
    assert [(t["label"], t["outcome"]) for t in transfers(parsed)] == [
        (f"{o.pick}→{o.place}", "placed") for o in judged.transfers
    ]
    samples = read_world_log(world_log_path(log))
    assert samples[0]["type"] == "scene"
    worlds = samples[1:]
    assert all(set(sample["tools"]) == {"PSM1", "PSM2"} for sample in worlds)
    first_blocks = next(sample for sample in worlds if sample.get("blocks"))
    truth = [np.array(block["pose"])[:3, 3] for block in first_blocks["truth"]]
    for block in first_blocks["blocks"]:  # perception's belief within 2 mm of the simulator's block
        nearest = min(np.linalg.norm(np.array(block["position"]) - position) for position in truth)
        assert nearest < 0.002
    cloud = np.array(next(sample["cloud"] for sample in worlds if "cloud" in sample)).reshape(-1, 3)
    assert 1000 < len(cloud) <= 8000
    tops = np.array(samples[0]["pegs"]["tops"])
    near_pegs = np.min(np.linalg.norm(cloud[:, None, :2] - tops[None, :, :2], axis=2), axis=1) < 0.002
    assert np.ptp(cloud[near_pegs, 2]) > 0.01  # in the board frame: the pegs stand above the board
