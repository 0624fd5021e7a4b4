"""The simulator endpoint: two PSMs, the pegboard world they act in and its depth camera, behind CRTK
topics over zenoh.

One thread owns all simulator state and runs a loop fed by an inbox. Zenoh callbacks only enqueue:
commands, camera triggers, step requests and queries. Commands are applied as they arrive (a `servo_jp` is
echoed on `setpoint_js` at once); time advances in control ticks of 10 ms:

- real time: a tick every 10 ms of wall time, stamps in epoch seconds; state published every tick.
- lockstep: ticks only when a client's `SimClock` asks (a put on `sim/step`, answered by a put on
  `sim/stepped/<client>`: cheaper than a query), stamps in simulated seconds from 0. Before stepping,
  the endpoint waits until it holds every command that client sent (the request carries its per-key
  counts); the reply carries the endpoint's own counts, so the client can wait for everything
  published on the way. The request also claims the state topics the client subscribes
  to: from then on their latest messages travel inside that client's step replies, not on the topics
  (one message per step instead of a dozen), unless loss or latency faults act on them. Every 50 ms
  of wall time the state is re-sent on its topics, so liveness checks hold, late joiners see it and
  other subscribers of claimed topics follow at that pace.

Each tick the world sees every tool where its *physical* joints put it (forward kinematics of the
cable physics' output, in the board frame); a jaw gripping a block stops at the block's wall, and its
`jaw/measured_js` says so. World events go to the `SimLog` (the `--log` file and `sim/events`); the
`sim/truth` query answers with block states and the log so far, for a judge, never for behaviours.

Each command's fate goes out tagged with the command's id: `operating_state` (accepted, done, aborted)
or `error` (refused, with the reason). Message loss, latency and a crash are injected per `FaultPlan`
(the world and camera inject their own faults) and logged with their time.
"""

from __future__ import annotations

import heapq
import itertools
import json
import queue
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import zenoh
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import DEFAULT_JOINTS, DEFAULT_SERVO_TAU, SimArm, Transition
from pegbt.sim.fault_plan import FaultInjector, FaultPlan
from pegbt.sim.log import SimLog
from pegbt.sim.plugins import SimCamera, SimWorld
from pegbt.sim.tools import ToolState
from pegbt.transport import codec
from pegbt.transport.arm import ARM_JOINT_NAMES, JAW_JOINT_NAMES
from pegbt.transport.keys import ArmKeys, CameraKeys, SimKeys
from pegbt.transport.sequencing import Bundled, Outlet, Source, Tag, bundle

MAX_STEPS_PER_REQUEST = 1_000_000
STATE_REFRESH = 1.0  # s of simulated time between unprompted operating_state messages
BARRIER_TIMEOUT = 5.0  # s to wait for a stepping client's commands to arrive


@dataclass(frozen=True)
class EndpointConfig:
    arms: tuple[str, ...] = ("PSM1", "PSM2")
    physics: str = "ideal"  # preset name or a JSON file (preset or sim-to-real report)
    lockstep: bool = False
    namespace: str = ""
    faults: FaultPlan = field(default_factory=FaultPlan)
    log_path: Path | None = None
    initial_joints: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    servo_tau: float = DEFAULT_SERVO_TAU
    heartbeat: float = 0.05  # s of wall time between re-sends of the state while a lockstep endpoint idles


Message = Callable[[], bytes]  # encodes a message when someone will receive it


@dataclass(frozen=True)
class _JointStateMessage:
    """A JointState, encoded when called; `content` (all but the stamp) tells an unchanged state."""

    stamp: float
    position: NDArray[np.float64]
    velocity: NDArray[np.float64] | tuple[()] = ()
    names: tuple[str, ...] = ()

    def __call__(self) -> bytes:
        return codec.encode_joint_state(self.stamp, self.position, self.velocity, names=self.names)

    def content(self) -> tuple[tuple[str, ...], bytes, bytes]:
        return self.names, self.position.tobytes(), np.asarray(self.velocity, dtype=float).tobytes()


@dataclass
class _Latest:
    """The latest message of a key: how to encode it, and its bytes once encoded."""

    message: Message | None
    cause: str
    outcome: str
    encoded: bytes | None = None

    def payload(self) -> bytes:
        if self.encoded is None:
            assert self.message is not None
            self.encoded = self.message()
        return self.encoded


class _Outbox:
    """Publishes tagged messages, losing or delaying them as the fault plan says (delays keep per-key order).

    A message is encoded only if someone subscribes to its key; otherwise it is kept, unencoded, as the
    key's latest, so that a heartbeat can still hand it to a late subscriber. A key a stepping client
    has `claimed` is not put at all: its latest goes back in that client's step replies (`latest`),
    and to other subscribers with the heartbeat.
    """

    def __init__(self, session: zenoh.Session, source: Source, faults: FaultInjector, log: Callable[..., None], realtime: bool) -> None:
        self._session = session
        self._source = source
        self._faults = faults
        self._faulty = faults.plan.loss_probability > 0 or faults.plan.latency > 0 or faults.plan.jitter > 0
        self._log = log
        self._realtime = realtime  # real time: express, and drop stale stream messages rather than block
        self._outlets: dict[str, Outlet] = {}
        self._delayed: list[tuple[float, int, str, bytes, str, str]] = []
        self._last: dict[str, _Latest] = {}
        self.inject = True  # off while publishing the initial state: every key starts with one message
        self._last_due: dict[str, float] = {}
        self._order = itertools.count()
        self.claimed: set[str] = set()
        self._replied: dict[str, dict[str, tuple[object, int]]] = {}  # per clock, per key: content and number last sent

    def outlet(self, key: str) -> Outlet:
        if key not in self._outlets:
            self._outlets[key] = Outlet(
                self._session, key, self._source, drop_when_congested=self._realtime, express=self._realtime
            )
        return self._outlets[key]

    def send(self, now: float, key: str, message: Message, cause: str = "", outcome: str = "") -> None:
        outlet = self.outlet(key)
        if key in self.claimed or not outlet.matched:
            self._last[key] = _Latest(message, cause, outcome)
            return
        if not (self.inject and self._faulty):
            self._put(outlet, _Latest(message, cause, outcome))
            return
        identity = f"{now:.6f}|{cause.partition(':')[2]}|{outcome}"  # without the sender's random name
        if self._faults.lost(key, identity):
            self._log(now, "fault", fault="loss", key=key)
            return
        delay = self._faults.delay(key, identity)
        if delay > 0:
            due = max(now + delay, self._last_due.get(key, 0.0))
            self._last_due[key] = due
            heapq.heappush(self._delayed, (due, next(self._order), key, message(), cause, outcome))
            self._log(now, "fault", fault="latency", key=key, seconds=round(due - now, 6))
            return
        self._put(outlet, _Latest(message, cause, outcome))

    def _put(self, outlet: Outlet, latest: _Latest) -> None:
        outlet.put(latest.payload(), latest.cause, latest.outcome)
        self._last[outlet.key] = latest

    def release(self, now: float) -> None:
        while self._delayed and self._delayed[0][0] <= now + 1e-9:
            _, _, key, payload, cause, outcome = heapq.heappop(self._delayed)
            self._put(self.outlet(key), _Latest(None, cause, outcome, payload))

    def latest(self, keys: set[str], clock: str) -> list[Bundled]:
        """The latest message of each claimed key among `keys`, tagged anew, for `clock`'s step reply: a
        joint state equal but for its stamp to the one it was last sent is a note with the new stamp
        (nothing to encode here or to decode there)."""
        replied = self._replied.setdefault(clock, {})
        messages: list[Bundled] = []
        for key in sorted(keys & self.claimed & self._last.keys()):
            latest = self._last[key]
            tag = self._source.next_tag(key, latest.cause, latest.outcome)
            message = latest.message
            content = message.content() if isinstance(message, _JointStateMessage) else None
            last = replied.get(key)
            if content is not None and last is not None and last[0] == content:
                messages.append((key, tag, {"restamp": codec.seconds_parts(message.stamp), "base": last[1]}))
            else:
                messages.append((key, tag, latest.payload()))
            replied[key] = (content, tag.seq)
        return messages

    def repeat(self, keys: set[str]) -> None:
        """Put the latest message of each of `keys` again, unchanged (same stamp, same values), to whoever listens."""
        for key in keys & self._last.keys():
            outlet = self.outlet(key)
            if outlet.matched:
                latest = self._last[key]
                outlet.put(latest.payload(), latest.cause, latest.outcome)

    def close(self) -> None:
        for outlet in self._outlets.values():
            outlet.close()


class SimEndpoint:
    """The simulator behind zenoh. `run()` serves until `stop()` or an injected crash."""

    def __init__(
        self,
        session: zenoh.Session,
        config: EndpointConfig = EndpointConfig(),
        *,
        world: SimWorld | None = None,
        camera: SimCamera | None = None,
    ) -> None:
        if camera is not None and world is None:
            raise PegbtError("a camera needs a world to look at", field="camera")
        self.session = session
        self.config = config
        self.world = world
        self.camera = camera
        self.arms = {
            name: SimArm(
                name,
                arm_settings(name),
                ArmPhysics.load(config.physics, name),
                q0=config.initial_joints.get(name, DEFAULT_JOINTS),
                servo_tau=config.servo_tau,
            )
            for name in config.arms
        }
        self._arm_to_board = {name: world.cell.arm_to_board(name) for name in self.arms} if world else {}
        self._events_logged = 0  # world events already in the log
        self.period = next(iter(self.arms.values())).period
        self.keys = {name: ArmKeys(name, config.namespace) for name in config.arms}
        self.sim_keys = SimKeys(config.namespace)
        self.camera_keys = CameraKeys(namespace=config.namespace)
        self.start_time = 0.0 if config.lockstep else time.time()
        self.time = self.start_time
        self.source = Source()
        self.faults = FaultInjector(config.faults)
        self._events_outlet = Outlet(session, self.sim_keys.events, self.source)
        self.log = SimLog(config.log_path, self._publish_log_line)
        self._outbox = _Outbox(session, self.source, self.faults, self.log.record, realtime=not config.lockstep)
        self._inbox: queue.Queue[tuple] = queue.Queue()
        self._received: dict[str, dict[str, int]] = {}
        self._received_lock = threading.Lock()
        self._delayed_commands: list[tuple[float, int, tuple]] = []
        self._order = itertools.count()
        self._untagged = itertools.count(1)
        self._last_state_refresh = self.time
        self._stop = threading.Event()
        self._declarations: list[Any] = []
        self._step_replies: dict[str, zenoh.Publisher] = {}  # per stepping clock
        self._declare()

    # ------------------------------------------------------------------ zenoh wiring
    @staticmethod
    def _arm_command_keys(keys: ArmKeys) -> tuple[str, ...]:
        return (keys.servo_jp, keys.move_jp, keys.follow_jt, keys.state_command, keys.jaw_servo_jp, keys.jaw_move_jp)

    @staticmethod
    def _state_keys(keys: ArmKeys) -> tuple[str, ...]:
        """An arm's state streams: only the latest message of each matters."""
        return (keys.measured_js, keys.setpoint_js, keys.fiducial_js, keys.measured_cp, keys.jaw_measured_js, keys.jaw_setpoint_js)

    def _declare(self) -> None:
        self._command_keys = {key for keys in self.keys.values() for key in self._arm_command_keys(keys)}
        # state a stepping client may take in its step replies; streams under loss or latency stay on their topics
        self._claimable = {
            key for keys in self.keys.values() for key in self._state_keys(keys) if not self.faults.affects(key)
        }
        for name, keys in self.keys.items():
            for key in self._arm_command_keys(keys):
                self._declarations.append(
                    self.session.declare_subscriber(key, lambda sample, k=key, a=name: self._enqueue_command(a, k, sample))
                )
            for key in (*self._state_keys(keys), keys.operating_state, keys.error):
                self._outbox.outlet(key)
        if self.camera is not None:
            self._outbox.outlet(self.camera_keys.points)
            self._command_keys.add(self.camera_keys.trigger)
            self._declarations.append(
                self.session.declare_subscriber(self.camera_keys.trigger, lambda sample: self._enqueue_command("", self.camera_keys.trigger, sample))
            )
        self._declarations.append(self.session.declare_queryable(self.sim_keys.clock, lambda q: self._inbox.put(("clock", q))))
        self._declarations.append(
            self.session.declare_subscriber(self.sim_keys.step, lambda sample: self._inbox.put(("step", sample.payload.to_bytes())))
        )
        self._declarations.append(self.session.declare_queryable(self.sim_keys.truth, lambda q: self._inbox.put(("truth", q))))

    def _enqueue_command(self, arm: str, key: str, sample: zenoh.Sample) -> None:
        tag = Tag.decode(sample.attachment)
        self._inbox.put(("command", arm, key, sample.payload.to_bytes(), tag))
        if tag is not None:  # counted after queueing, so a satisfied barrier means the command is queued
            with self._received_lock:
                counts = self._received.setdefault(tag.source, {})
                counts[key] = max(counts.get(key, 0), tag.seq)

    # ------------------------------------------------------------------ the loop
    def stop(self) -> None:
        self._stop.set()

    def run(self) -> str:
        """Serve until stopped ("stopped") or until an injected crash ("crashed")."""
        self.log.record(self.elapsed, "start", mode="lockstep" if self.config.lockstep else "realtime",
                        physics=self.config.physics, arms=list(self.arms))
        if self.world is not None:
            self._update_world()
        self._outbox.inject = False
        self._publish_operating_states()
        self._publish_state()
        self._outbox.inject = True
        next_tick = time.time() + self.period
        last_beat = time.monotonic()
        while not self._stop.is_set():
            if self.config.lockstep:
                timeout = max(0.0, self.config.heartbeat - (time.monotonic() - last_beat))
            else:
                timeout = max(0.0, next_tick - time.time())
            try:
                item = self._inbox.get(timeout=timeout)
            except queue.Empty:
                item = None
            if item is not None:
                self._handle(item)
            if self.faults.crashed:
                return "crashed"
            if self.config.lockstep:
                if time.monotonic() - last_beat >= self.config.heartbeat:
                    self._send_heartbeat()
                    last_beat = time.monotonic()
                continue
            if time.time() >= next_tick:
                if time.time() - next_tick > 10 * self.period:  # fell far behind (machine busy): skip, don't burst
                    next_tick = time.time()
                self.time = next_tick
                self._tick()
                self._publish_state()
                next_tick += self.period
        return "stopped"

    @property
    def elapsed(self) -> float:
        """Simulated seconds since start (fault times are given in these)."""
        return self.time - self.start_time

    def now(self) -> float:
        """Stamp for something happening between ticks."""
        return self.time if self.config.lockstep else max(self.time, time.time())

    def _handle(self, item: tuple) -> None:
        kind = item[0]
        if kind == "command":
            self._command(*item[1:])
        elif kind == "clock":
            self._reply(item[1], {"mode": "lockstep" if self.config.lockstep else "realtime", "period": self.period, "time": self.now(),
                                  "source": self.source.name, "sent": self.source.counts()})
        elif kind == "step":
            self._step(item[1])
        elif kind == "truth":
            self._answer_truth(item[1])

    # ------------------------------------------------------------------ lockstep
    def _step(self, payload: bytes) -> None:
        """A step request: wait for the client's commands, tick, answer with the state it claims."""
        try:
            request = json.loads(payload)
            clock, source, number = str(request["clock"]), str(request["source"]), int(request["number"])
        except (ValueError, TypeError, KeyError):
            return  # not a SimClock's request: there is nobody to answer
        try:
            steps = int(request.get("steps", 1))
            if not self.config.lockstep:
                raise PegbtError("the simulator runs in real time; sim/step needs --lockstep", field="steps")
            if not 0 < steps <= MAX_STEPS_PER_REQUEST:
                raise PegbtError(f"steps must be in 1..{MAX_STEPS_PER_REQUEST}, got {steps}", field="steps")
            self._await_commands(source, request.get("sent", {}))
            claim = set(map(str, request.get("claim", []))) & self._claimable
        except (PegbtError, ValueError, TypeError) as error:
            self._answer_step(clock, {"number": number, "error": str(error)}, [])
            return
        self._outbox.claimed |= claim
        for _ in range(steps):
            if self.faults.crashed:
                break
            self.time = self.start_time + round((self.elapsed + self.period) / self.period) * self.period
            self._tick()
        if self.faults.crashed:
            return
        self._publish_state()
        state = self._outbox.latest(claim, clock)
        header = {"number": number, "time": self.time, "source": self.source.name, "sent": self.source.counts()}
        self._answer_step(clock, header, state)

    def _answer_step(self, clock: str, header: dict[str, Any], state: list[Bundled]) -> None:
        if clock not in self._step_replies:
            self._step_replies[clock] = self.session.declare_publisher(  # never dropped: the client waits for it
                self.sim_keys.stepped(clock), express=True, congestion_control=zenoh.CongestionControl.BLOCK
            )
        self._step_replies[clock].put(bundle(header, state))

    def _await_commands(self, source: str, sent: Mapping[str, int]) -> None:
        """Handle every command `source` sent before asking to step (zenoh orders keys independently)."""
        ours = set(sent) & self._command_keys
        deadline = time.monotonic() + BARRIER_TIMEOUT
        while True:
            with self._received_lock:
                counts = dict(self._received.get(source, {}))
            if all(counts.get(key, 0) >= int(sent[key]) for key in ours):
                break
            if time.monotonic() > deadline:
                raise PegbtError(f"commands from {source} never arrived: wanted {sent}, have {counts}", field="sent")
            try:
                item = self._inbox.get(timeout=0.001)
            except queue.Empty:
                continue
            self._defer_or_handle(item)
        while True:  # everything counted is queued: drain it
            try:
                item = self._inbox.get_nowait()
            except queue.Empty:
                break
            self._defer_or_handle(item)

    def _defer_or_handle(self, item: tuple) -> None:
        if item[0] == "step":  # another client's step waits its turn
            self._inbox.put(item)
        else:
            self._handle(item)

    @staticmethod
    def _reply(query: zenoh.Query, answer: dict | str) -> None:
        query.reply(query.key_expr, answer if isinstance(answer, str) else json.dumps(answer), express=True)
        query.drop()

    def _answer_truth(self, query: zenoh.Query) -> None:
        """Block states and the log from the asked index on: the judge's view, JSON."""
        try:
            request = json.loads(query.payload.to_bytes()) if query.payload is not None else {}
            since = int(request.get("since", 0))
            if since < 0:
                raise ValueError(f"since must be >= 0, got {since}")
        except (ValueError, TypeError, AttributeError) as error:
            query.reply_err(str(error))
            query.drop()
            return
        blocks = json.dumps(self.world.snapshot()["blocks"] if self.world is not None else [])
        lines = self.log.lines
        log = ",".join(lines[since:])
        self._reply(query, f'{{"time": {self.elapsed!r}, "blocks": {blocks}, "log": [{log}], "next": {len(lines)}}}')

    # ------------------------------------------------------------------ commands
    def _command(self, arm: str, key: str, payload: bytes, tag: Tag | None) -> None:
        number = tag.seq if tag is not None else next(self._untagged)
        command_id = tag.command_id(key) if tag is not None else f"untagged:{key}:{number}"
        now = self.now()
        identity = str(number)  # not the sender's random name: the same script draws the same faults
        if self.faults.lost(key, identity):
            self.log.record(self.elapsed, "fault", fault="loss", key=key, command=number)
            return
        delay = self.faults.delay(key, identity)
        if delay > 0:
            self.log.record(self.elapsed, "fault", fault="latency", key=key, command=number, seconds=round(delay, 6))
            heapq.heappush(self._delayed_commands, (now + delay, next(self._order), (arm, key, payload, command_id)))
            return
        self._apply(arm, key, payload, command_id)

    def _apply(self, arm_name: str, key: str, payload: bytes, command_id: str) -> None:
        if key == self.camera_keys.trigger:
            self._capture(command_id)
            return
        arm, keys = self.arms[arm_name], self.keys[arm_name]
        try:
            if key == keys.follow_jt:
                _, trajectory = codec.decode_trajectory(payload)
                transitions = arm.follow_jt(trajectory.t, trajectory.q, trajectory.qd, command_id)
            elif key == keys.state_command:
                transitions = arm.state_command(codec.decode_string_stamped(payload)[1], command_id)
            else:
                position = codec.decode_joint_state(payload).position
                handler = {
                    keys.servo_jp: arm.servo_jp,
                    keys.move_jp: arm.move_jp,
                    keys.jaw_servo_jp: arm.jaw_servo_jp,
                    keys.jaw_move_jp: arm.jaw_move_jp,
                }[key]
                transitions = handler(position, command_id)
        except PegbtError as error:
            transitions = [Transition(command_id, "refused", error.message)]
        self._publish_transitions(arm_name, key, transitions)
        refused = any(t.outcome == "refused" and t.command_id == command_id for t in transitions)
        if not refused and key == keys.servo_jp:
            self._publish_setpoint(arm_name, jaw=False)
        elif not refused and key == keys.jaw_servo_jp:
            self._publish_setpoint(arm_name, jaw=True)

    def _publish_transitions(self, arm_name: str, key: str, transitions: list[Transition]) -> None:
        keys, now = self.keys[arm_name], self.now()
        for transition in transitions:
            if transition.outcome == "refused":
                text = f"{key} refused: {transition.text}"
                self.log.record(self.elapsed, "refused", arm=arm_name, key=key, command=transition.command_id, reason=transition.text)
                self._outbox.send(now, keys.error, partial(codec.encode_string, text), transition.command_id, "refused")
            else:
                self._publish_operating_state(arm_name, transition.command_id, transition.outcome)

    # ------------------------------------------------------------------ ticks
    def _tick(self) -> None:
        while self._delayed_commands and self._delayed_commands[0][0] <= self.time + 1e-9:
            self._apply(*heapq.heappop(self._delayed_commands)[2])
        for name, arm in self.arms.items():
            for transition in arm.advance(self.period):
                self._publish_operating_state(name, transition.command_id, transition.outcome)
        if self.world is not None:
            self._update_world()
        if self.time - self._last_state_refresh >= STATE_REFRESH - 1e-9:
            self._publish_operating_states()
        self._outbox.release(self.time)
        if self.faults.crash_due(self.elapsed):
            self.log.record(self.elapsed, "fault", fault="crash")

    def _update_world(self) -> None:
        """Move the world with each tool where its physical joints put it; a gripped block stops the jaw."""
        assert self.world is not None
        tools = {
            name: ToolState.from_joints(arm.physical, float(arm.jaw.encoder[0]), self._arm_to_board[name])
            for name, arm in self.arms.items()
        }
        self.world.update(self.elapsed, tools)
        for name, arm in self.arms.items():
            arm.jaw.stop_at(self.world.jaw_stop(name))
        self._log_world_events()

    def _log_world_events(self) -> None:
        """Put the world's new events (from a step, or a capture's noise burst) in the simulator's log."""
        assert self.world is not None
        events = self.world.events
        for event in events.since(self._events_logged):
            self.log.record_event(event)
        self._events_logged = len(events)

    # ------------------------------------------------------------------ publishing
    def _publish_operating_state(self, name: str, cause: str = "", outcome: str = "") -> None:
        arm = self.arms[name]
        state = codec.OperatingState(self.now(), arm.state, arm.is_homed, arm.is_busy)
        self._outbox.send(self.now(), self.keys[name].operating_state, partial(codec.encode_operating_state, state), cause, outcome)

    def _publish_operating_states(self) -> None:
        self._last_state_refresh = self.time
        for name in self.arms:
            self._publish_operating_state(name)

    def _publish_setpoint(self, name: str, jaw: bool) -> None:
        arm, keys, now = self.arms[name], self.keys[name], self.now()
        if jaw:
            self._outbox.send(now, keys.jaw_setpoint_js, _JointStateMessage(now, arm.jaw.setpoint, names=JAW_JOINT_NAMES))
        else:
            self._outbox.send(now, keys.setpoint_js, _JointStateMessage(now, arm.joints.setpoint, names=ARM_JOINT_NAMES))

    def _publish_state(self) -> None:
        """Every arm's state now. An arm's arrays are replaced each tick, never changed in place, so a
        message kept unencoded (nobody listens yet) still shows this instant when a late subscriber gets it."""
        now, send, joint_state = self.time, self._outbox.send, _JointStateMessage
        for name, arm in self.arms.items():
            keys, joints, jaw = self.keys[name], arm.joints, arm.jaw
            send(now, keys.measured_js, joint_state(now, joints.encoder, joints.velocity, names=ARM_JOINT_NAMES))
            send(now, keys.jaw_measured_js, joint_state(now, jaw.encoder, jaw.velocity, names=JAW_JOINT_NAMES))
            send(now, keys.fiducial_js, joint_state(now, arm.physical, names=ARM_JOINT_NAMES))
            send(now, keys.measured_cp, partial(_encode_pose, now, joints.encoder, f"{name}_base"))
            self._publish_setpoint(name, jaw=False)
            self._publish_setpoint(name, jaw=True)

    def _publish_log_line(self, line: str) -> None:
        """A log entry on `sim/events`, to whoever listens: a message numbered for nobody would hold up the
        lockstep barrier of a client that subscribed later."""
        if self._events_outlet.matched:
            self._events_outlet.put(codec.encode_string(line))

    def _send_heartbeat(self) -> None:
        """Re-send each arm's latest state, unchanged, on its topics: a lockstep endpoint is seen alive
        while idle, late joiners see its state, and subscribers of claimed keys get it at this pace;
        faults are not drawn again, so what a client sees stays deterministic."""
        self._outbox.repeat({key for keys in self.keys.values() for key in (*self._state_keys(keys), keys.operating_state)})

    def _capture(self, command_id: str) -> None:
        assert self.camera is not None and self.world is not None
        now = self.now()
        points = self.camera.capture(self.world, self.elapsed)
        self._log_world_events()
        self._outbox.send(now, self.camera_keys.points, partial(codec.encode_point_cloud, now, points), command_id, "done")

    # ------------------------------------------------------------------ shutdown
    def close(self) -> None:
        for declaration in [*self._declarations, *self._step_replies.values()]:
            declaration.undeclare()
        self._outbox.close()
        self._events_outlet.close()
        self.log.close()


def _encode_pose(stamp: float, joints: NDArray[np.float64], frame_id: str) -> bytes:
    """`measured_cp`: the tip pose the encoders put the tool at, in the arm's base frame."""
    return codec.encode_pose_stamped(stamp, forward_kinematics(joints), frame_id)
