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
from typing import NoReturn

from pegbt.errors import PegbtError

STAGE_PREFIX = "pegbt sim: reached "  # a start-up stage (--report-stages), before the serving line
SERVING_PREFIX = "pegbt sim: serving"  # the line that ends start-up: clients may connect
# s for the child to reach its next start-up stage (or to serve, from the last). The longest stage, loading
# open3d, takes 2.8 s on a quiet core: this leaves room for a machine 20 times slower (load 20 on 2 cores).
STAGE_TIMEOUT = 60.0
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
                "--report-stages",
                *args,
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        try:
            await_serving(self.process, STAGE_TIMEOUT)
        except PegbtError:
            self.stop()
            raise

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


def await_serving(child: subprocess.Popen[str], stage_timeout: float) -> None:
    """Return once `child` (a `pegbt sim --report-stages`) says it serves. Its start-up is bounded by its
    progress, not by a fixed time: each stage it reports restarts the bound, so a loaded machine's slow but
    steady start succeeds, while a child that reaches no next stage within `stage_timeout` s is killed.
    That child, one that exits, or one that prints anything else is a `PegbtError` naming the last stage."""
    assert child.stdout is not None
    fd = child.stdout.fileno()  # read raw: a text reader's buffer would hide lines from the selector
    pending = b""
    stage = ""
    with selectors.DefaultSelector() as selector:
        selector.register(fd, selectors.EVENT_READ)
        while True:
            while b"\n" not in pending:
                if not selector.select(stage_timeout):
                    stuck = f"no progress within {stage_timeout:g} s after {stage!r}" if stage else ""
                    _give_up(child, stuck or f"nothing within {stage_timeout:g} s")
                chunk = os.read(fd, 4096)
                if not chunk:
                    child.wait(timeout=EXIT_TIMEOUT)
                    _give_up(
                        child,
                        f"it exited (status {child.returncode})" + (f" after {stage!r}" if stage else ""),
                    )
                pending += chunk
            raw, pending = pending.split(b"\n", 1)
            line = raw.decode(errors="replace").strip()
            if line.startswith(SERVING_PREFIX):
                return
            if not line.startswith(STAGE_PREFIX):
                _give_up(child, line)
            stage = line.removeprefix(STAGE_PREFIX)


def _give_up(child: subprocess.Popen[str], said: str) -> NoReturn:
    """Kill a child that did not start and raise what it reached, with what it wrote on stderr."""
    child.kill()
    _, err = child.communicate(timeout=EXIT_TIMEOUT)
    raise PegbtError(
        f"pegbt sim did not start: {said}{': ' + err.strip() if err.strip() else ''}", field="sim"
    )
