"""SCHED_FIFO where the system permits it (root, or an `rtprio` limit): the processes that keep real time.

A dVRK's controller runs its loop at real-time priority, so a busy computer delays the client, never the
robot's servo loop. pegbt's simulator stands in for that controller, the servo streamer is the client's
one timed process; each asks for SCHED_FIFO before it opens its zenoh session, so that zenoh's threads
inherit it. Where the system refuses, they run under the ordinary scheduler and say so.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

STREAMER_PRIORITY = 10  # SCHED_FIFO, 1..99: above every ordinary process, below the kernel's own threads
ROBOT_PRIORITY = 20  # the robot (or what stands in for it) above the client that streams to it


def run_realtime(priority: int) -> bool:
    """Run this process, and the threads it starts later, under SCHED_FIFO at `priority`, if permitted."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (AttributeError, OSError):  # not Linux, or no permission: the ordinary scheduler
        return False
    return True


@contextmanager
def realtime_priority(priority: int | None) -> Iterator[bool]:
    """`run_realtime(priority)` for the body (None: the ordinary scheduler), and this thread's policy as it
    was after it, so a caller that goes on (a refused command run in-process, a test) is not left in
    SCHED_FIFO. Yields whether SCHED_FIFO was granted."""
    if priority is None:
        yield False
        return
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    granted = run_realtime(priority)
    try:
        yield granted
    finally:
        if granted:
            os.sched_setscheduler(0, policy, param)
