"""The robot side of `pegbt bench servo`, in its own process (`python -m pegbt.bench.servo_listener CONNECT`):
publishes PSM1's `setpoint_js` (where a streamer starts from) every 10 ms and notes when each `servo_jp`
arrives. When its standard input closes it prints one JSON object and exits: `arrivals`, one
`[received, stamp]` per set-point (wall-clock seconds: when it arrived, and the header stamp the sender
wrote as it sent it); `wake_late`, how late its own 10 ms timer woke each time (s), the floor of what this
process can measure on this machine at this moment; and `realtime`, whether it ran under SCHED_FIFO, as a
robot's controller does, when the system permits (`pegbt.transport.streamer.realtime`)."""

from __future__ import annotations

import json
import sys
import threading
import time

import numpy as np

from pegbt.scheduling import ROBOT_PRIORITY, run_realtime
from pegbt.transport import codec
from pegbt.transport.dvrk_topics import PsmTopics
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import endpoint_settings, open_session

SETPOINT = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
PERIOD = 0.01  # s between the robot's set-point messages


def main() -> int:
    topics = PsmTopics("PSM1")
    arrivals: list[tuple[float, bytes]] = []
    wake_late: list[float] = []
    is_realtime = run_realtime(
        ROBOT_PRIORITY
    )  # as a robot's controller; before the session opens, so that zenoh's threads inherit it
    with open_session(endpoint_settings([sys.argv[1]])) as session:
        wire = BridgeWire(session)
        wire.subscriber(topics.servo_jp, lambda payload: arrivals.append((time.time(), payload)))
        setpoint, jaw = wire.publisher(topics.setpoint_js), wire.publisher(topics.jaw_setpoint_js)
        stop = threading.Event()

        def publish() -> None:
            due = time.monotonic() + PERIOD
            while not stop.wait(max(0.0, due - time.monotonic())):
                wake_late.append(time.monotonic() - due)
                due += PERIOD
                setpoint.put(codec.encode_joint_state(time.time(), SETPOINT))
                jaw.put(codec.encode_joint_state(time.time(), [0.0]))

        thread = threading.Thread(target=publish, daemon=True)
        thread.start()
        print("ready", flush=True)
        sys.stdin.read()
        stop.set()
        thread.join()
    received = [(at, codec.decode_joint_state(payload).stamp) for at, payload in arrivals]
    print(json.dumps({"arrivals": received, "wake_late": wake_late, "realtime": is_realtime}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
