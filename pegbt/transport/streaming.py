"""The executive's side of the servo streamer (`pegbt.transport.streamer`): start it, hand it whole
trajectories, and follow each one to its end with a `StreamedMotion` that behaviours poll like any motion.
The streamer's stalls (it was not scheduled, and resumed the motions it was playing) and its pauses (an arm
in MANUAL: its clutch pressed) become warnings for the tick log (`drain_messages`); a motion's time bound
grows by both."""

from __future__ import annotations

import io
import itertools
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.transport.arm import EndpointSilent, MotionStatus, StatusFlags
from pegbt.transport.streamer import FrameReader, encode_frame

STARTUP_TIMEOUT = 30.0  # s for the streamer to import, connect and say it is ready (a loaded machine)
EXIT_TIMEOUT = 5.0  # s for it to hold and exit when told to quit
MOTION_MARGIN = (
    2.0  # s a streamed motion may overrun its duration (a late start, a slow machine) before it fails
)


class Streamer:
    """A running streamer process for the arms in `settings`, connected to `connect` under `namespace`."""

    def __init__(
        self,
        connect: Sequence[str],
        namespace: str,
        settings: dict[str, ArmSettings],
        period: float,
        ros2: str = "bridge",
    ) -> None:
        root = Path(__file__).resolve().parents[2]
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")])),
        }
        self._stderr = (
            tempfile.TemporaryFile()
        )  # never a pipe nobody reads: a full one would stall the stream
        self.process = subprocess.Popen(
            [sys.executable, "-m", "pegbt.transport.streamer"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            env=env,
        )
        self.period = period
        self._ids = itertools.count(1)
        self._outcomes: dict[int, tuple[str, str]] = {}
        self._started: set[int] = set()
        self._axes: dict[int, str] = {}  # what each motion moves ("PSM1 arm"), to say which one stalled
        self._stalled: dict[
            int, float
        ] = {}  # s each motion stood still, the streamer not scheduled or paused
        self._paused_since: dict[int, float] = {}  # monotonic time each paused motion was paused
        self._messages: list[dict[str, Any]] = []
        self._changed = threading.Condition()
        self._ready = False
        self.realtime = False  # whether the streamer runs under SCHED_FIFO (see `pegbt.transport.streamer`)
        self._gone = False
        self._write_lock = threading.Lock()
        self._send(
            (
                "configure",
                {
                    "connect": list(connect),
                    "namespace": namespace,
                    "ros2": ros2,
                    "arms": settings,
                    "period": period,
                },
            )
        )
        threading.Thread(target=self._read_reports, name="streamer reports", daemon=True).start()
        with self._changed:
            self._changed.wait_for(lambda: self._ready or self._gone, STARTUP_TIMEOUT)
        if not self._ready:
            self._stderr.seek(0)
            said = self._stderr.read().decode(errors="replace").strip()
            self.close()
            raise PegbtError(
                f"the servo streamer did not start: {said or f'not ready within {STARTUP_TIMEOUT:g} s'}",
                field="streamer",
            )

    def _send(self, message: tuple[Any, ...]) -> None:
        assert self.process.stdin is not None
        try:
            with self._write_lock:
                self.process.stdin.write(encode_frame(message))
                self.process.stdin.flush()
        except (BrokenPipeError, ValueError):
            self._gone = True
            raise EndpointSilent("the servo streamer has exited", field="streamer") from None

    def _read_reports(self) -> None:
        reader, stdout = FrameReader(), self.process.stdout
        assert isinstance(stdout, io.BufferedReader)  # a binary pipe, buffered (Popen's default)
        while data := stdout.read1(65536):
            for frame in reader.feed(data):
                with self._changed:
                    if frame[0] == "ready":
                        self._ready, self.realtime = True, bool(frame[1])
                    elif frame[0] == "started":
                        self._started.add(frame[1])
                    elif frame[0] == "stalled":
                        self._messages.append(self._stall_message(frame[1], frame[2]))
                        self._stalled[frame[1]] = self._stalled.get(frame[1], 0.0) + float(frame[2])
                    elif frame[0] == "paused":
                        self._paused_since.setdefault(frame[1], time.monotonic())
                        self._messages.append(self._message(f"{frame[2]}: no set-point until it is released"))
                    elif frame[0] == "resumed":
                        self._paused_since.pop(frame[1], None)
                        self._stalled[frame[1]] = self._stalled.get(frame[1], 0.0) + float(frame[2])
                        self._messages.append(
                            self._message(
                                f"{self._axes.get(frame[1], 'a motion')}: released; goes on from where the arm "
                                f"is, {float(frame[2]):.1f} s later"
                            )
                        )
                    else:
                        self._outcomes[frame[1]] = (frame[0], frame[2] if len(frame) > 2 else "")
                        self._axes.pop(frame[1], None)
                        self._paused_since.pop(frame[1], None)
                    self._changed.notify_all()
        with self._changed:
            self._gone = True
            self._changed.notify_all()

    def _stall_message(self, motion_id: int, seconds: float) -> dict[str, Any]:
        return self._message(
            f"{self._axes.get(motion_id, 'a motion')}: no set-point for {seconds:.3f} s (the streamer was "
            "not scheduled); the trajectory resumed from its last set-point and ends that much later"
        )

    @staticmethod
    def _message(text: str) -> dict[str, Any]:
        return {"source": "streamer", "level": "warning", "text": text, "stamp": time.time()}

    def drain_messages(self) -> list[dict[str, Any]]:
        """Tick-log `message` records of the stalls since the last call, oldest first."""
        with self._changed:
            messages, self._messages = self._messages, []
        return messages

    @property
    def running(self) -> bool:
        return not self._gone and self.process.poll() is None

    def play(self, arm: str, axis: str, t: ArrayLike, q: ArrayLike) -> int:
        """Hand a trajectory (`t` from 0, rows of `q`) of `arm`'s `axis` (`arm` or `jaw`) to the streamer; its id."""
        motion_id = next(self._ids)
        self._axes[motion_id] = f"{arm} {axis}"
        self._send(("play", motion_id, arm, axis, np.asarray(t, dtype=float), np.asarray(q, dtype=float)))
        return motion_id

    def ramp(self, arm: str, start: float, goal: float) -> int:
        """Hand `arm`'s jaw a ramp to `goal` at its velocity to the streamer; its id. It starts from the last
        set-point the streamer sent while the jaw's stream is going (it knows that row, the robot's echo
        comes later), else from `start`."""
        motion_id = next(self._ids)
        self._axes[motion_id] = f"{arm} jaw"
        self._send(("ramp", motion_id, arm, float(start), float(goal)))
        return motion_id

    def stop(self, motion_id: int) -> None:
        self._send(("stop", motion_id))

    def stalled(self, motion_id: int) -> float:
        """Seconds the motion stood still because the streamer was not scheduled or its arms were in MANUAL,
        as it reported them, and the time of a pause still going on."""
        with self._changed:
            since = self._paused_since.get(motion_id)
            return self._stalled.get(motion_id, 0.0) + (0.0 if since is None else time.monotonic() - since)

    def outcome(self, motion_id: int) -> tuple[str, str] | None:
        """`("done", "")` or `("failed", reason)` once the streamer has said; None while it plays."""
        with self._changed:
            return self._outcomes.get(motion_id)

    def close(self) -> None:
        """Tell it to quit (it holds any arm still moving) and wait; kill it if it does not go."""
        if self.process.poll() is None:
            try:
                self._send(("quit",))
                self.process.wait(timeout=EXIT_TIMEOUT)
            except (EndpointSilent, subprocess.TimeoutExpired):
                self.process.kill()
                self.process.wait(timeout=EXIT_TIMEOUT)
        for stream in (self.process.stdin, self.process.stdout, self._stderr):
            if stream is not None:
                stream.close()


class StreamedMotion(StatusFlags):
    """A trajectory the streamer plays: poll `status` (busy, done, failed), or `stop()` it.

    It is done once the streamer has sent its last set-point and `arrived()` says the robot has taken it
    (its `setpoint_js` where the next motion may start: `crtk_arm.taken_up` for an arm). It fails if
    the streamer refuses a set-point, if it is not done `margin` s after its duration and the stalls the
    streamer reported (the arm held still through them; it is then stopped), or when `check_alive` (the
    robot's liveness) raises. When the streamer gives up on it, `check_failure` may raise what the
    robot's own state says (an arm the robot faulted stops the run rather than failing one motion)."""

    def __init__(
        self,
        streamer: Streamer,
        motion_id: int,
        what: str,
        duration: float,
        check_alive: Callable[[], None],
        arrived: Callable[[], bool],
        margin: float = MOTION_MARGIN,
        check_failure: Callable[[], None] | None = None,
    ) -> None:
        self._streamer = streamer
        self._check_failure = check_failure
        self._arrived = arrived
        self.motion_id = motion_id
        self.what = what
        self.bound = duration + margin
        self._deadline = time.monotonic() + self.bound
        self._check_alive = check_alive
        self.error: str | None = None
        self._done = False

    @property
    def status(self) -> MotionStatus:
        if self.error is not None:
            return MotionStatus.FAILED
        if self._done:
            return MotionStatus.DONE
        outcome = self._streamer.outcome(self.motion_id)
        if outcome is not None and outcome[0] != "done":
            if self._check_failure is not None:
                self._check_failure()
            self.error = f"{self.what} failed: {outcome[1]}"
            return MotionStatus.FAILED
        if outcome is not None and self._arrived():
            self._done = True
            return MotionStatus.DONE
        if not self._streamer.running:
            raise EndpointSilent(f"the servo streamer exited during {self.what}", field="streamer")
        self._check_alive()
        if time.monotonic() > self._deadline + self.paused:
            self._streamer.stop(self.motion_id)
            stalls = f" and {self.paused:.1f} s of stalls" if self.paused else ""
            self.error = f"{self.what} not done within {self.bound:.1f} s{stalls}; stopped"
            return MotionStatus.FAILED
        return MotionStatus.BUSY

    @property
    def paused(self) -> float:
        return self._streamer.stalled(self.motion_id)

    def stop(self) -> None:
        """Stop streaming it; the arm holds where its last set-point put it."""
        if self.status is MotionStatus.BUSY:
            self._streamer.stop(self.motion_id)
            self.error = f"{self.what} stopped by the client"
