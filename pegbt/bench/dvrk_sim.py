"""`pegbt bench dvrk-sim`: whether the simulator's dVRK interface holds the dVRK's 10 ms publishing period.

Two parts. In this process, a `DvrkEndpoint` with the world (no network peer) is stepped through 1000 control
periods while both arms follow a `move_jp` back and forth: the work of one period (`tick_ms_*`: arms,
world) and of publishing the states (`publish_ms_*`), and the wall time a camera frame spends ray-casting
in its parts (`camera_frame_ms_p50`), against the 10 ms budget (`period_ms`). Then `pegbt sim --interface
dvrk` runs in its own process with world and camera for `SECONDS`, and a raw zenoh subscriber in this one
measures the intervals between the `PSM1/measured_js` messages it receives (`state_interval_ms_*`,
`state_gap_ms_max`) and the clouds' rate (`camera_hz`); the simulator's log counts its overruns.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np

from pegbt.bench import Figures

SECONDS = 8.0
PERIODS = 1000


def _in_process() -> Figures:
    from pegbt.sim.camera import DepthCamera
    from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig
    from pegbt.sim.world import World
    from pegbt.transport.ros2 import BridgeWire
    from pegbt.transport.session import SessionSettings, open_session

    session = open_session(SessionSettings())
    world, camera = World(0), DepthCamera(seed=0)
    endpoint = DvrkEndpoint(BridgeWire(session), DvrkEndpointConfig(), world=world)
    try:
        for arm in endpoint.arms.values():
            arm.state_command("home")
        ticks, publishes = [], []
        goals = ([0.3, 0.2, 0.14, 0.5, 0.3, 0.2], [-0.3, -0.2, 0.12, -0.5, -0.3, -0.2])
        for k in range(PERIODS):
            endpoint.time = endpoint.start_time + (k + 1) * endpoint.period
            for arm in endpoint.arms.values():
                if arm.is_homed and not arm.is_busy:
                    arm.move_jp(goals[(k // 150) % 2])
            started = time.perf_counter()
            endpoint._tick()
            ticked = time.perf_counter()
            endpoint._publish_states()
            ticks.append(ticked - started)
            publishes.append(time.perf_counter() - ticked)
        frames = []
        for _ in range(5):
            started = time.perf_counter()
            exposure = camera.expose(world)
            while not exposure.done:
                exposure.cast(8192)
            exposure.points()
            frames.append(time.perf_counter() - started)
    finally:
        endpoint.close()
        session.close()
    return {
        "period_ms": round(endpoint.period * 1e3, 3),
        "tick_ms_p50": round(float(np.median(ticks)) * 1e3, 3),
        "tick_ms_p99": round(float(np.percentile(ticks, 99)) * 1e3, 3),
        "publish_ms_p50": round(float(np.median(publishes)) * 1e3, 3),
        "publish_ms_p99": round(float(np.percentile(publishes, 99)) * 1e3, 3),
        "camera_frame_ms_p50": round(float(np.median(frames)) * 1e3, 2),
    }


def _as_a_process() -> Figures:
    from pegbt.sim.process import SimProcess
    from pegbt.transport.session import client_settings, open_session

    arrivals: list[float] = []
    clouds: list[float] = []
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "sim.jsonl"
        with SimProcess(["--log", str(log)], interface="dvrk") as sim:
            session = open_session(client_settings([sim.endpoint]))
            try:
                states = session.declare_subscriber(
                    "PSM1/measured_js", lambda _: arrivals.append(time.perf_counter())
                )
                points = session.declare_subscriber(
                    "camera/camera/depth/color/points", lambda _: clouds.append(time.perf_counter())
                )
                time.sleep(SECONDS)
                states.undeclare()
                points.undeclare()
            finally:
                session.close()
        entries = [json.loads(line) for line in log.read_text().splitlines()]
    overruns = [entry for entry in entries if entry["kind"] == "overrun"]
    intervals = np.diff(arrivals[len(arrivals) // 8 :])  # after the start-up's first second or so
    return {
        "state_interval_ms_p50": round(float(np.median(intervals)) * 1e3, 3),
        "state_interval_ms_p99": round(float(np.percentile(intervals, 99)) * 1e3, 3),
        "state_gap_ms_max": round(float(intervals.max()) * 1e3, 1),
        "camera_hz": round((len(clouds) - 1) / (clouds[-1] - clouds[0]), 2) if len(clouds) > 1 else 0.0,
        "overrun_runs": len(overruns),
        "overrun_periods": sum(entry["periods"] for entry in overruns),
        "run_periods": round(SECONDS / 0.01),
    }


def run() -> Figures:
    return {**_in_process(), **_as_a_process()}
