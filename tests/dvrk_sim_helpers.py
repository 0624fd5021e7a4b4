"""The simulator's dVRK interface served from a thread of the test's process, on a free loopback port."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig
from pegbt.sim.process import free_port
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import endpoint_settings, open_session


class ServedSim:
    """A `DvrkEndpoint` (no world) serving at `address` until `close()`."""

    def __init__(self, log_path: Path, **config: Any) -> None:
        self.address = f"tcp/127.0.0.1:{free_port()}"
        self.session = open_session(endpoint_settings([self.address]))
        self.endpoint = DvrkEndpoint(
            BridgeWire(self.session), DvrkEndpointConfig(log_path=log_path, **config)
        )
        self.thread = threading.Thread(target=self.endpoint.run, name="dvrk-sim", daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.endpoint.stop()
        self.thread.join(timeout=10)
        self.endpoint.close()
        self.session.close()
