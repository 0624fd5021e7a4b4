"""SIGTERM and SIGINT as a stop the executive handles: both become `Stopped`, a `KeyboardInterrupt`, so
the runner halts the tree (every running leaf stops its arm), writes the halt and end records, and the
command exits with the signal's own status (128 + its number: 130 for SIGINT, 143 for SIGTERM).

Why: by default SIGTERM (what a supervisor, systemd or `kill` sends) ends Python at once: no halt, no
end record, no stop sent to the arms. A second signal while the first is being handled is ignored, so
the halt it started is not cut short.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Stopped(KeyboardInterrupt):
    """A stop asked for by a signal; `status` is the process exit status that says which."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum
        self.status = 128 + signum


class Received:
    """The first stop signal received while `stop_signals` was in force (None if none)."""

    def __init__(self) -> None:
        self.signum: int | None = None

    @property
    def name(self) -> str:
        return signal.Signals(self.signum).name if self.signum is not None else ""

    @property
    def status(self) -> int:
        return 128 + (self.signum or 0)


@contextmanager
def stop_signals() -> Iterator[Received]:
    """Within the block, SIGINT and SIGTERM raise `Stopped` once (then are ignored); handlers are restored
    after. Outside the main thread (where Python cannot take signals) nothing is installed."""
    received = Received()
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def handle(signum: int, frame: FrameType | None) -> None:
        if received.signum is not None:
            return  # already stopping: let the halt finish
        received.signum = signum
        raise Stopped(signum)

    previous = {signum: signal.signal(signum, handle) for signum in SIGNALS}
    try:
        yield received
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
