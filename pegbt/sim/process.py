"""`pegbt sim` as a child process on a free loopback port: for tests and benchmarks that need the
endpoint in another process, as it is in use."""

from __future__ import annotations

import os
import selectors
import socket
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from pegbt.errors import PegbtError

STARTUP_TIMEOUT = 30.0  # s for the child to say it serves
EXIT_TIMEOUT = 5.0  # s for a killed or terminated child to be gone


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


class SimProcess:
    """A `pegbt sim` child listening on a free port; `endpoint` is where clients connect. It stops with
    this process, however this one ends: its standard input is a pipe from here (`--stop-with-parent`).
    `interface` is `pegbt sim --interface`: "pegbt" (pegbt's topics and extensions) or "dvrk" (a dVRK's).
    With a `router` (a ROS 2 graph's zenoh router), the dVRK interface joins that graph over rmw_zenoh
    (`--ros2 rmw_zenoh`) instead of listening, and `endpoint` is the router."""

    def __init__(
        self,
        args: Sequence[str] = (),
        port: int | None = None,
        interface: str = "pegbt",
        router: str | None = None,
    ) -> None:
        self.port = port or free_port()
        self.endpoint = router or f"tcp/127.0.0.1:{self.port}"
        where = ["--ros2", "rmw_zenoh", "--connect", router] if router else ["--listen", self.endpoint]
        root = Path(__file__).resolve().parents[2]
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")])),
        }
        self.process = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "pegbt",
                "sim",
                "--interface",
                interface,
                *where,
                "--stop-with-parent",
                *args,
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        line = self._first_line(STARTUP_TIMEOUT)
        if not line.startswith("pegbt sim: serving"):
            self.process.kill()
            _, err = self.process.communicate(timeout=EXIT_TIMEOUT)
            said = f"{line.strip()} {err.strip()}".strip() or f"nothing within {STARTUP_TIMEOUT:g} s"
            raise PegbtError(f"pegbt sim did not start: {said}", field="sim")

    def _first_line(self, timeout: float) -> str:
        """The child's first line of output, or "" if it prints none within `timeout` s (a hung start-up)."""
        assert self.process.stdout is not None
        with selectors.DefaultSelector() as selector:
            selector.register(self.process.stdout, selectors.EVENT_READ)
            if not selector.select(timeout):
                return ""
        return self.process.stdout.readline()  # the child prints its line whole and flushes it

    def kill(self) -> None:
        """SIGKILL: the endpoint vanishes without a word, as a crashed one does."""
        self.process.kill()
        self.process.wait(timeout=EXIT_TIMEOUT)

    def wait(self, timeout: float) -> int:
        return self.process.wait(timeout=timeout)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=EXIT_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.kill()
        for stream in (self.process.stdin, self.process.stdout, self.process.stderr):
            if stream is not None:
                stream.close()

    def __enter__(self) -> SimProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
