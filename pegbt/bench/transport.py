"""`pegbt bench transport`: servo round trip through the simulator, raw zenoh round trip, CDR cost.

- `servo_rtt_p50_ms`, `servo_rtt_p99_ms`: `ArmClient.servo_jp` at 100 Hz until the matching
  `setpoint_js` arrives, against `pegbt sim` (real time) in another process, on loopback.
- `raw_rtt_p50_ms`, `raw_rtt_p99_ms`: the baseline in the same run: a bare zenoh put echoed back by a
  bare zenoh process (same payload size, same rate), no CDR, no simulator.
- `cdr_us`: encode + decode of one sensor_msgs/JointState (median).
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
import timeit
from collections.abc import Callable

import numpy as np
import zenoh

from pegbt.sim.process import SimProcess, free_port
from pegbt.transport import ArmClient, codec, connect
from pegbt.transport.session import client_settings, endpoint_settings, open_session

SAMPLES = 400
RATE_HZ = 100.0
PING, PONG = "bench/ping", "bench/pong"


def _percentiles(seconds: list[float]) -> tuple[float, float]:
    values = np.array(seconds) * 1e3
    return float(np.percentile(values, 50)), float(np.percentile(values, 99))


def _paced(send: Callable[[int], None], arrived: threading.Event) -> list[float]:
    """Send SAMPLES messages at RATE_HZ; each round trip from send until `arrived` is set."""
    trips = []
    next_send = time.perf_counter()
    for index in range(SAMPLES):
        arrived.clear()
        start = time.perf_counter()
        send(index)
        if arrived.wait(1.0):
            trips.append(time.perf_counter() - start)
        next_send += 1 / RATE_HZ
        time.sleep(max(0.0, next_send - time.perf_counter()))
    return trips


def _servo_round_trips() -> list[float]:
    with SimProcess(["--physics", "ideal"]) as sim, connect([sim.endpoint]) as link:
        psm1 = ArmClient(link, "PSM1")
        psm1.wait_until_ready()
        home = psm1.setpoint_js.position
        targets = [home + [1e-4 * (i % 2), 0, 0, 0, 0, 0] for i in range(SAMPLES)]
        wanted: list[np.ndarray] = [targets[0]]
        arrived = threading.Event()

        def on_setpoint(sample: zenoh.Sample) -> None:
            if np.array_equal(codec.decode_joint_state(sample.payload.to_bytes()).position, wanted[0]):
                arrived.set()

        subscriber = link.session.declare_subscriber(psm1.keys.setpoint_js, on_setpoint)

        def send(index: int) -> None:
            wanted[0] = targets[index]
            psm1.servo_jp(targets[index])

        trips = _paced(send, arrived)
        subscriber.undeclare()
        return trips


def _raw_round_trips(payload_size: int) -> list[float]:
    port = free_port()
    echo = subprocess.Popen(
        [sys.executable, "-m", "pegbt.bench.transport", "echo", f"tcp/127.0.0.1:{port}"],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert echo.stdout is not None  # stdout=PIPE
    try:
        echo.stdout.readline()  # "ready"
        session = open_session(client_settings([f"tcp/127.0.0.1:{port}"]))
        arrived = threading.Event()
        subscriber = session.declare_subscriber(PONG, lambda sample: arrived.set())
        publisher = session.declare_publisher(PING, express=True)
        while not publisher.matching_status.matching:  # type: ignore[attr-defined]  # zenoh's stub says bool; it is a MatchingStatus
            time.sleep(0.01)
        payload = bytes(payload_size)
        trips = _paced(lambda index: publisher.put(payload), arrived)
        subscriber.undeclare()
        publisher.undeclare()
        session.close()
        return trips
    finally:
        echo.terminate()
        echo.wait(timeout=5)


def _echo(listen: str) -> None:
    """A bare zenoh process that sends every ping straight back."""
    session = open_session(endpoint_settings([listen]))
    pong = session.declare_publisher(PONG, express=True)
    session.declare_subscriber(PING, lambda sample: pong.put(sample.payload))
    print("ready", flush=True)
    try:
        while True:
            time.sleep(1)
    except KeyboardInterrupt:
        pass


def _cdr_us() -> float:
    q = np.linspace(-0.5, 0.5, 6)
    names = tuple(f"joint{i}" for i in range(6))

    def once() -> None:
        codec.decode_joint_state(codec.encode_joint_state(12.5, q, q, names=names))

    once()
    return float(np.median([timeit.timeit(once, number=200) / 200 for _ in range(15)]) * 1e6)


def run() -> dict[str, float | int | str]:
    payload_size = len(codec.encode_joint_state(0.0, np.zeros(6), names=tuple("abcdef")))
    servo = _percentiles(_servo_round_trips())
    raw = _percentiles(_raw_round_trips(payload_size))
    return {
        "servo_rtt_p50_ms": servo[0],
        "servo_rtt_p99_ms": servo[1],
        "raw_rtt_p50_ms": raw[0],
        "raw_rtt_p99_ms": raw[1],
        "cdr_us": _cdr_us(),
        "samples": SAMPLES,
        "rate_hz": RATE_HZ,
    }


if __name__ == "__main__" and sys.argv[1:2] == ["echo"]:
    _echo(sys.argv[2])
