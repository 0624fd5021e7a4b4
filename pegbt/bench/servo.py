"""`pegbt bench servo`: how steadily set-points reach a robot while the executive works.

A separate process (`servo_listener`, standing for the robot) notes when each PSM1 `servo_jp` arrives, while
this process does the executive's heavy work without pause: a 10 Hz camera (the simulator's ray-cast
capture of the pegboard), block registration on each cloud (`BlockLocator`), and transfer planning (SQP)
in between. Two streams of the same 100 Hz set-points are measured under the same load:

- `process_*`: the servo streamer (`pegbt.transport.streamer`), its own process, as `--interface dvrk` runs it;
- `thread_*`: the baseline: a thread of this process sleeping to the same deadlines.

For each: `p50`/`p99` of |interval − control period| between arrivals (ms) and the longest gap (ms).
Goal: p99 ≤ 2 ms, no gap over 20 ms. Where that deviation comes from: `send_*`, the same
deviation between the stamps the sender wrote as it sent (its own timing), and `latency_*`, arrival minus
stamp (zenoh's send and receive paths and the listener's wake-up). `listener_wake_p99_ms` is how late the
listener's own 10 ms timer woke: what the measurement cannot resolve on this machine at that moment.
`*_realtime` says whether the streamer and the listener ran under SCHED_FIFO (allowed here or not).
Each figure is the median over `REPEATS` streams of each kind.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from pegbt.bench import Figures

SECONDS = 10.0  # of streaming per variant
REPEATS = 3  # streams of each kind, alternated
CAMERA_PERIOD = 0.1  # s: a 10 Hz camera


def _trajectory(period: float) -> tuple[np.ndarray, np.ndarray]:
    """A slow yaw sway from the listener's set-point, `SECONDS` long, sampled every `period`."""
    from pegbt.bench.servo_listener import SETPOINT

    t = np.arange(0.0, SECONDS, period)
    q = np.repeat(SETPOINT[None], len(t), axis=0)
    q[:, 0] += 0.2 * np.sin(2 * np.pi * t / 4.0)
    return t, q


class _Listener:
    """The `servo_listener` child on a free loopback port."""

    def __init__(self) -> None:
        from pegbt.sim.process import free_port

        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        root = Path(__file__).resolve().parents[2]
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")])),
        }
        self.process = subprocess.Popen(
            [sys.executable, "-m", "pegbt.bench.servo_listener", self.endpoint],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        assert self.process.stdout is not None
        if self.process.stdout.readline().strip() != "ready":
            raise RuntimeError("servo listener did not start")

    def report(self) -> dict:
        """What it noted (see `servo_listener`)."""
        out, _ = self.process.communicate(timeout=30)  # closes its standard input: it prints and exits
        return json.loads(out.strip().splitlines()[-1])


class _Load:
    """The executive's work: capture at 10 Hz, register the blocks of each capture, plan transfers between."""

    def __init__(self) -> None:
        from pegbt.motion.limits import arm_settings
        from pegbt.motion.transfer import TransferPlanner
        from pegbt.motion.waypoints import transfer_waypoints
        from pegbt.perception.blocks import BlockLocator
        from pegbt.perception.board import PegboardRegistration
        from pegbt.sim.camera import DepthCamera
        from pegbt.sim.world import World
        from pegbt.workcell import UNILATERAL_ORDER, workcell

        self.world = World(seed=0)
        self.camera = DepthCamera(seed=0, include_arms=False)
        self.board = PegboardRegistration(self.world.cell).fit(self.camera.capture(self.world))
        self.locator = BlockLocator()
        settings = arm_settings("PSM1")
        self.planner = TransferPlanner(settings)
        cell = workcell()
        tops, up = cell.peg_tops_in("PSM1"), cell.up_in("PSM1")
        self.transfers = [transfer_waypoints(tops[a], tops[b], up=up) for a, b in UNILATERAL_ORDER]
        self.planner.plan(self.transfers[0])

    def run(self, seconds: float) -> tuple[int, int]:
        """Work for `seconds`; how many captures were registered and transfers planned."""
        end = time.monotonic() + seconds
        next_capture, captures, plans = time.monotonic(), 0, 0
        while time.monotonic() < end:
            if time.monotonic() >= next_capture:  # a camera that falls behind drops frames, as a stream does
                next_capture = max(next_capture + CAMERA_PERIOD, time.monotonic())
                self.locator.locate(self.camera.capture(self.world), self.board)
                captures += 1
            self.planner.plan(self.transfers[plans % len(self.transfers)])
            plans += 1
        return captures, plans


def _figures(prefix: str, report: dict, period: float) -> Figures:
    arrivals = np.array(report["arrivals"]).reshape(-1, 2)
    received, sent = arrivals[:, 0], arrivals[:, 1]
    intervals = np.diff(received)
    deviation = np.abs(intervals - period) * 1e3
    send_deviation = np.abs(np.diff(sent) - period) * 1e3
    latency = (received - sent) * 1e3
    return {
        f"{prefix}_setpoints": int(len(arrivals)),
        f"{prefix}_p50_ms": float(np.percentile(deviation, 50)),
        f"{prefix}_p99_ms": float(np.percentile(deviation, 99)),
        f"{prefix}_longest_gap_ms": float(intervals.max() * 1e3),
        f"{prefix}_send_p50_ms": float(np.percentile(send_deviation, 50)),
        f"{prefix}_send_p99_ms": float(np.percentile(send_deviation, 99)),
        f"{prefix}_latency_p50_ms": float(np.percentile(latency, 50)),
        f"{prefix}_latency_p99_ms": float(np.percentile(latency, 99)),
        f"{prefix}_listener_wake_p99_ms": float(np.percentile(report["wake_late"], 99) * 1e3),
        f"{prefix}_listener_realtime": int(report["realtime"]),
    }


Start = Callable[[str], tuple[Callable[[], None], bool]]


def _under_load(load: _Load, start: Start) -> tuple[dict, bool, int, int]:
    """Start a stream to a fresh listener (`start(endpoint)` returns how to stop it and whether the sender
    runs under SCHED_FIFO), load this process while it plays; what the listener noted, that flag, and the
    work done."""
    listener = _Listener()
    stop, is_realtime = start(listener.endpoint)
    time.sleep(0.5)
    captures, plans = load.run(SECONDS - 1.0)
    stop()
    return listener.report(), is_realtime, captures, plans


def _process_stream(endpoint: str) -> tuple[Callable[[], None], bool]:
    from pegbt.motion.limits import arm_settings
    from pegbt.transport.streaming import Streamer

    settings = arm_settings("PSM1")
    streamer = Streamer([endpoint], "", {"PSM1": settings}, settings.control_period)
    time.sleep(0.5)  # the streamer's session has met the listener's
    streamer.play("PSM1", "arm", *_trajectory(settings.control_period))
    return streamer.close, streamer.realtime


def _thread_stream(endpoint: str) -> tuple[Callable[[], None], bool]:
    from pegbt.motion.limits import arm_settings
    from pegbt.transport import codec
    from pegbt.transport.dvrk_topics import PsmTopics
    from pegbt.transport.ros2 import BridgeWire
    from pegbt.transport.session import client_settings, open_session

    period = arm_settings("PSM1").control_period
    session = open_session(client_settings([endpoint]))
    publisher = BridgeWire(session).publisher(PsmTopics("PSM1").servo_jp)
    _, q = _trajectory(period)
    done = threading.Event()

    def stream() -> None:
        deadline = time.monotonic()
        for row in q:
            if done.is_set():
                return
            time.sleep(max(0.0, deadline - time.monotonic()))
            publisher.put(codec.encode_joint_state(time.time(), row))
            deadline += period

    thread = threading.Thread(target=stream, daemon=True)
    time.sleep(0.5)
    thread.start()

    def stop() -> None:
        done.set()
        thread.join()
        session.close()

    return stop, False


def run() -> Figures:
    from pegbt.motion.limits import arm_settings

    period = arm_settings("PSM1").control_period
    load = _Load()
    figures: Figures = {"control_period_ms": period * 1e3, "seconds_per_stream": SECONDS, "repeats": REPEATS}
    runs: dict[str, list[Figures]] = {"process": [], "thread": []}
    for _ in range(REPEATS):
        for prefix, start in (("process", _process_stream), ("thread", _thread_stream)):
            report, is_realtime, captures, plans = _under_load(load, start)
            run_figures = _figures(prefix, report, period)
            run_figures[f"{prefix}_realtime"] = int(is_realtime)
            run_figures[f"{prefix}_load_captures_registered"] = captures
            run_figures[f"{prefix}_load_transfers_planned"] = plans
            runs[prefix].append(run_figures)
    for repeats in runs.values():
        for name in repeats[0]:
            figures[name] = float(np.median([float(run[name]) for run in repeats]))
    figures["goal"] = "p99 <= 2 ms, longest gap <= 20 ms"
    return figures
