"""Commands: from a message on an arm's command topic to what the simulated arm does with it.

A client commands an arm as it would a dVRK, with CRTK messages: `servo_jp` and `move_jp` (a
JointState's positions), `follow_jt` (a JointTrajectory), `jaw/servo_jp`, `jaw/move_jp` and
`state_command` (a StringStamped). Each message is one command, named by its tag: `source:key:number`
(`untagged:key:n` for a sender without tags, such as a ROS 2 bridge). Every report on the command,
`operating_state` (accepted, done, aborted) or `error` (refused, with the reason), carries that id,
so a client knows exactly when *its* command was decided.

Commands meet the network's faults on the way in, as the simulator's messages do on the way out: a
lost command is never applied, a delayed one is applied at the first tick after it is due. A draw
depends on the command's number, not on the sender's random name, so the same script meets the same
faults. A payload that does not decode is refused like a command outside the limits: whole, with the
reason, never half applied.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Iterator
from dataclasses import dataclass

from pegbt.errors import PegbtError
from pegbt.sim.arm import SimArm, Transition
from pegbt.sim.fault_plan import FaultInjector
from pegbt.sim.log import SimLog
from pegbt.transport import codec
from pegbt.transport.keys import ArmKeys
from pegbt.transport.sequencing import Tag


def command_keys(keys: ArmKeys) -> tuple[str, ...]:
    """The keys on which an arm takes commands."""
    return (
        keys.servo_jp,
        keys.move_jp,
        keys.follow_jt,
        keys.state_command,
        keys.jaw_servo_jp,
        keys.jaw_move_jp,
        keys.hold,
        keys.jaw_hold,
    )


@dataclass(frozen=True)
class Command:
    """A command as it arrived: for `arm` (empty for the camera) on `key`, its payload and its id, and the
    command it is about (`cause`: the motion a hold stops)."""

    arm: str
    key: str
    payload: bytes
    command_id: str
    cause: str = ""


class CommandIntake:
    """Names arriving commands and puts them through the fault plan's loss and latency."""

    def __init__(self, faults: FaultInjector, log: SimLog) -> None:
        self._faults = faults
        self._log = log
        self._delayed: list[tuple[float, int, Command]] = []
        self._order = itertools.count()
        self._untagged = itertools.count(1)

    def admit(
        self, arm: str, key: str, payload: bytes, tag: Tag | None, now: float, elapsed: float
    ) -> Command | None:
        """The command to apply now; None if it is lost or delayed (then `due` hands it over later)."""
        number = tag.seq if tag is not None else next(self._untagged)
        command = Command(
            arm,
            key,
            payload,
            tag.command_id(key) if tag is not None else f"untagged:{key}:{number}",
            tag.cause if tag is not None else "",
        )
        identity = str(number)
        if self._faults.lost(key, identity):
            self._log.record(elapsed, "fault", fault="loss", key=key, command=number)
            return None
        delay = self._faults.delay(key, identity)
        if delay > 0:
            self._log.record(
                elapsed, "fault", fault="latency", key=key, command=number, seconds=round(delay, 6)
            )
            heapq.heappush(self._delayed, (now + delay, next(self._order), command))
            return None
        return command

    def due(self, now: float) -> Iterator[Command]:
        """The delayed commands due by `now`, in the order they fall due."""
        while self._delayed and self._delayed[0][0] <= now + 1e-9:
            yield heapq.heappop(self._delayed)[2]


def dispatch(arm: SimArm, keys: ArmKeys, command: Command) -> list[Transition]:
    """Decode `command` and hand it to `arm`: what became of it (and of any motion it preempted)."""
    key, payload, command_id = command.key, command.payload, command.command_id
    try:
        if key == keys.follow_jt:
            _, trajectory = codec.decode_trajectory(payload)
            return arm.follow_jt(trajectory.t, trajectory.q, trajectory.qd, command_id)
        if key == keys.state_command:
            return arm.state_command(codec.decode_string_stamped(payload)[1], command_id)
        if key in (keys.hold, keys.jaw_hold):
            return arm.hold(key == keys.jaw_hold, command_id, command.cause)
        position = codec.decode_joint_state(payload).position
        handler = {
            keys.servo_jp: arm.servo_jp,
            keys.move_jp: arm.move_jp,
            keys.jaw_servo_jp: arm.jaw_servo_jp,
            keys.jaw_move_jp: arm.jaw_move_jp,
        }[key]
        return handler(position, command_id)
    except PegbtError as error:
        return [Transition(command_id, "refused", error.message)]


def refused(transitions: list[Transition], command_id: str) -> bool:
    """Whether `transitions` refuse the command `command_id`."""
    return any(t.outcome == "refused" and t.command_id == command_id for t in transitions)
