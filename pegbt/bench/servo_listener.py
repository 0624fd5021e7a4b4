"""The robot side of `pegbt bench servo`, in its own process (`python -m pegbt.bench.servo_listener CONNECT`):
publishes PSM1's `setpoint_js` (where a streamer starts from) and notes when each `servo_jp` arrives; when its
standard input closes it prints the arrival times (monotonic seconds) as one JSON line and exits."""

from __future__ import annotations

import json
import sys
import threading
import time

import numpy as np

from pegbt.transport import codec
from pegbt.transport.dvrk_topics import PsmTopics
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import endpoint_settings, open_session

SETPOINT = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])


def main() -> int:
    topics = PsmTopics("PSM1")
    arrivals: list[float] = []
    with open_session(endpoint_settings([sys.argv[1]])) as session:
        wire = BridgeWire(session)
        wire.subscriber(topics.servo_jp, lambda _: arrivals.append(time.monotonic()))
        setpoint, jaw = wire.publisher(topics.setpoint_js), wire.publisher(topics.jaw_setpoint_js)
        stop = threading.Event()

        def publish() -> None:
            while not stop.wait(0.01):
                setpoint.put(codec.encode_joint_state(time.time(), SETPOINT))
                jaw.put(codec.encode_joint_state(time.time(), [0.0]))

        thread = threading.Thread(target=publish, daemon=True)
        thread.start()
        print("ready", flush=True)
        sys.stdin.read()
        stop.set()
        thread.join()
    print(json.dumps(arrivals), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
