"""The simulator endpoint: two PSMs, the pegboard world they act in and its depth camera, behind CRTK
topics over zenoh, as a dVRK's arms are behind its ROS 2 topics.

The endpoint composes the simulator's parts and runs its loop on one thread. Zenoh callbacks put what
arrives in an inbox (commands, camera triggers, step requests, queries); the endpoint's loop takes it
from there, so simulator state changes in one order. In real time an arm command is the exception: its
callback applies it at once under the endpoint's lock, which the loop holds while it handles an item or
ticks (a servo round trip then skips a hand-over between threads, about a third of its cost on a busy
machine). Its parts, each with one job:

- `SimArm` (`arm`): one arm's controller, limits, servo response and cable physics;
- `Scene` (`scene`): the world moved by the arms' physical joints, its events put in the log;
- `commands`: a command message to the arm call it asks for, through loss and latency faults;
- `outbox`: every published message, encoded only when received, through loss and latency faults;
- `lockstep`: step requests, and the barrier that makes each step see exactly what was sent before it;
- `truth`: the judge's `sim/truth` query; `log` (`SimLog`): the ground-truth log behind it.

Time advances in control ticks of 10 ms. In real time a tick comes every 10 ms of wall time, stamps
are epoch seconds and the state goes out every tick. In lockstep ticks come only when a client's
`SimClock` asks, stamps are simulated seconds from 0, and every 50 ms of wall time the state is re-sent
on its topics (a heartbeat), so liveness checks hold, late joiners see it and subscribers of keys a
stepping client claimed follow at that pace.

Each tick the world sees every tool where its *physical* joints put it (forward kinematics of the
cable physics' output, in the board frame); a jaw gripping a block stops at the block's wall, and its
`jaw/measured_js` says so, as a real gripper's encoder would. A command is applied as it arrives (a
`servo_jp` is echoed on `setpoint_js` at once); a motion plays out over the ticks that follow. Loss and
latency act on commands and published messages, the world and camera inject their own faults, and an
injected crash ends `run()` at its simulated time; each fault is logged with that time.
"""

from __future__ import annotations

import json
import queue
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import zenoh
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.psm import ARMS
from pegbt.sim.arm import DEFAULT_JOINTS, DEFAULT_SERVO_TAU, SimArm, Transition
from pegbt.sim.commands import Command, CommandIntake, command_keys, dispatch, refused
from pegbt.sim.fault_plan import FaultInjector, FaultPlan
from pegbt.sim.interfaces import SimCamera, SimWorld
from pegbt.sim.lockstep import Inbox, Lockstep
from pegbt.sim.log import SimLog
from pegbt.sim.outbox import JointStateMessage, Outbox
from pegbt.sim.scene import Scene
from pegbt.sim.truth import requested_since, truth_answer
from pegbt.transport import codec
from pegbt.transport.arm import ARM_JOINT_NAMES, JAW_JOINT_NAMES
from pegbt.transport.keys import ArmKeys, CameraKeys, SimKeys
from pegbt.transport.sequencing import BadTag, Outlet, Source, Tag

if TYPE_CHECKING:
    from pegbt.transport.recorder import WireRecorder

STATE_REFRESH = 1.0  # s of simulated time between unprompted operating_state messages


@dataclass(frozen=True)
class EndpointConfig:
    """How to run the simulator: its arms, their cable physics, lockstep or real time, the key namespace,
    injected faults, the log file, the arms' starting joints and servo response."""

    arms: tuple[str, ...] = ARMS
    physics: str = "ideal"  # preset name or a JSON file (preset or sim-to-real report)
    lockstep: bool = False
    namespace: str = ""
    faults: FaultPlan = field(default_factory=FaultPlan)
    log_path: Path | None = None
    initial_joints: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    servo_tau: float = DEFAULT_SERVO_TAU
    heartbeat: float = 0.05  # s of wall time between re-sends of the state while a lockstep endpoint idles


def _state_keys(keys: ArmKeys) -> tuple[str, ...]:
    """An arm's state streams: only the latest message of each matters."""
    return (
        keys.measured_js,
        keys.setpoint_js,
        keys.fiducial_js,
        keys.measured_cp,
        keys.jaw_measured_js,
        keys.jaw_setpoint_js,
    )


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
        self.period = next(iter(self.arms.values())).period
        self.keys = {name: ArmKeys(name, config.namespace) for name in config.arms}
        self.sim_keys = SimKeys(config.namespace)
        self.camera_keys = CameraKeys(namespace=config.namespace)
        self.start_time = 0.0 if config.lockstep else time.time()
        self.time = self.start_time
        self.source = Source()
        self.bad_tags = 0  # commands refused because their attachment was not a tag
        self.faults = FaultInjector(config.faults)
        self._events_outlet = Outlet(session, self.sim_keys.events, self.source)
        self._recorder: WireRecorder | None = None
        self.log = SimLog(config.log_path, self._publish_log_line)
        self._scene = Scene(world, self.arms, self.log) if world is not None else None
        self._outbox = Outbox(
            session, self.source, self.faults, self.log.record, realtime=not config.lockstep
        )
        self._commands = CommandIntake(self.faults, self.log)
        self._inbox: Inbox = queue.Queue()
        self._last_state_refresh = self.time
        self._stop = threading.Event()
        self._lock = threading.Lock()  # real time: the loop or a command's callback, one at a time
        self._declarations: list[Any] = []
        commands = {key for keys in self.keys.values() for key in command_keys(keys)}
        if camera is not None:
            commands.add(self.camera_keys.trigger)
        # streams under loss or latency stay on their topics, where the faults act
        claimable = {
            key for keys in self.keys.values() for key in _state_keys(keys) if not self.faults.affects(key)
        }
        self._lockstep = Lockstep(
            session,
            self.sim_keys,
            self._outbox,
            self._inbox,
            self._handle,
            enabled=config.lockstep,
            command_keys=commands,
            claimable=claimable,
        )
        self._declare()

    # ------------------------------------------------------------------ zenoh wiring
    def _declare(self) -> None:
        """Subscribe to commands, step requests and queries; declare every state and report key."""
        for name, keys in self.keys.items():
            for key in command_keys(keys):
                self._declarations.append(
                    self.session.declare_subscriber(key, partial(self._enqueue_command, name, key))
                )
            for key in (*_state_keys(keys), keys.operating_state, keys.error):
                self._outbox.outlet(key)
        if self.camera is not None:
            self._outbox.outlet(self.camera_keys.points)
            self._declarations.append(
                self.session.declare_subscriber(
                    self.camera_keys.trigger,
                    lambda sample: self._enqueue_command("", self.camera_keys.trigger, sample),
                )
            )
        self._declarations.append(
            self.session.declare_queryable(self.sim_keys.clock, lambda q: self._inbox.put(("clock", q)))
        )
        self._declarations.append(
            self.session.declare_subscriber(
                self.sim_keys.step, lambda sample: self._inbox.put(("step", sample.payload.to_bytes()))
            )
        )
        self._declarations.append(
            self.session.declare_queryable(self.sim_keys.truth, lambda q: self._inbox.put(("truth", q)))
        )

    def record(self, recorder: WireRecorder) -> None:
        """Show `recorder` every command taken, every message published or bundled, every log line."""
        self._recorder = recorder
        self._outbox.record(recorder.sent)

    def _enqueue_command(self, arm: str, key: str, sample: zenoh.Sample) -> None:
        try:
            tag = Tag.decode(sample.attachment)
        except BadTag as error:
            self._inbox.put(("bad tag", arm, key, error.message))
            return
        payload = sample.payload.to_bytes()
        if self._recorder is not None:
            self._recorder.sent(key, payload)
        if arm and not self.config.lockstep:  # an arm command in real time: applied now (a capture waits)
            with self._lock:
                if not self._stop.is_set():
                    self._command(arm, key, payload, tag)
        else:
            self._inbox.put(("command", arm, key, payload, tag))
        if tag is not None:
            self._lockstep.arrived(tag, key)

    # ------------------------------------------------------------------ the loop
    def stop(self) -> None:
        self._stop.set()

    def run(self) -> str:
        """Serve until stopped ("stopped") or until an injected crash ("crashed")."""
        self.log.record(
            self.elapsed,
            "start",
            mode="lockstep" if self.config.lockstep else "realtime",
            physics=self.config.physics,
            arms=list(self.arms),
        )
        if self._scene is not None:
            self._scene.update(self.elapsed)
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
            with self._lock:
                if item is not None:
                    self._handle(item)
                if self.faults.crashed:
                    self._stop.set()
                    return "crashed"
                if self.config.lockstep:
                    if time.monotonic() - last_beat >= self.config.heartbeat:
                        self._send_heartbeat()
                        last_beat = time.monotonic()
                    continue
                if time.time() >= next_tick:
                    if (
                        time.time() - next_tick > 10 * self.period
                    ):  # fell far behind (machine busy): skip, don't burst
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

    # ------------------------------------------------------------------ what arrives
    def _handle(self, item: tuple) -> None:
        """Act on one inbox item: a command, a step request, or a `sim/clock` or `sim/truth` query."""
        kind = item[0]
        if kind == "command":
            self._command(*item[1:])
        elif kind == "clock":
            clock = {
                "mode": "lockstep" if self.config.lockstep else "realtime",
                "period": self.period,
                "time": self.now(),
                "source": self.source.name,
                "sent": self.source.counts(),
            }
            self._reply(item[1], json.dumps(clock))
        elif kind == "step":
            self._step(item[1])
        elif kind == "truth":
            self._answer_truth(item[1])
        elif kind == "bad tag":
            self._refuse_untagged(*item[1:])

    def _step(self, payload: bytes) -> None:
        """A step request: once the lockstep barrier admits it, tick and answer with the state it claims."""
        request = self._lockstep.admit(payload)
        if request is None:
            return
        for _ in range(request.steps):
            if self.faults.crashed:
                break
            self.time = self.start_time + round((self.elapsed + self.period) / self.period) * self.period
            self._tick()
        if self.faults.crashed:
            return
        self._publish_state()
        self._lockstep.answer(
            request, {"time": self.time, "source": self.source.name, "sent": self.source.counts()}
        )

    @staticmethod
    def _reply(query: zenoh.Query, answer: str) -> None:
        query.reply(query.key_expr, answer, express=True)
        query.drop()

    def _answer_truth(self, query: zenoh.Query) -> None:
        """Block states and the log from the asked index on: the judge's view, JSON."""
        try:
            since = requested_since(query.payload.to_bytes() if query.payload is not None else None)
        except ValueError as error:
            query.reply_err(str(error))
            query.drop()
            return
        blocks = self.world.snapshot()["blocks"] if self.world is not None else []
        self._reply(query, truth_answer(self.elapsed, blocks, self.log.lines, since))

    def _refuse_untagged(self, arm: str, key: str, reason: str) -> None:
        """A command whose attachment is not a tag: not applied (whose command it is cannot be told),
        logged and said on the arm's error topic."""
        self.bad_tags += 1
        self.log.record(
            self.elapsed, "refused", arm=arm, key=key, command="", reason=f"bad attachment: {reason}"
        )
        if arm in self.keys:
            text = f"{key} refused: bad attachment: {reason}"
            self._outbox.send(
                self.now(), self.keys[arm].error, partial(codec.encode_string, text), "", "refused"
            )

    def _command(self, arm: str, key: str, payload: bytes, tag: Tag | None) -> None:
        command = self._commands.admit(arm, key, payload, tag, self.now(), self.elapsed)
        if command is not None:
            self._apply(command)

    def _apply(self, command: Command) -> None:
        """Carry out `command` and publish what became of it; an accepted servo_jp is echoed on setpoint_js."""
        if command.key == self.camera_keys.trigger:
            self._capture(command.command_id)
            return
        keys = self.keys[command.arm]
        transitions = dispatch(self.arms[command.arm], keys, command)
        self._publish_transitions(command.arm, command.key, transitions)
        if refused(transitions, command.command_id):
            return
        if command.key == keys.servo_jp:
            self._publish_setpoint(command.arm, jaw=False)
        elif command.key == keys.jaw_servo_jp:
            self._publish_setpoint(command.arm, jaw=True)

    def _publish_transitions(self, arm_name: str, key: str, transitions: list[Transition]) -> None:
        keys, now = self.keys[arm_name], self.now()
        for transition in transitions:
            if transition.outcome == "refused":
                text = f"{key} refused: {transition.text}"
                self.log.record(
                    self.elapsed,
                    "refused",
                    arm=arm_name,
                    key=key,
                    command=transition.command_id,
                    reason=transition.text,
                )
                self._outbox.send(
                    now, keys.error, partial(codec.encode_string, text), transition.command_id, "refused"
                )
            else:
                self._publish_operating_state(arm_name, transition.command_id, transition.outcome)

    # ------------------------------------------------------------------ ticks
    def _tick(self) -> None:
        for command in self._commands.due(self.time):
            self._apply(command)
        for name, arm in self.arms.items():
            for transition in arm.advance(self.period):
                self._publish_operating_state(name, transition.command_id, transition.outcome)
        if self._scene is not None:
            self._scene.update(self.elapsed)
        if self.time - self._last_state_refresh >= STATE_REFRESH - 1e-9:
            self._publish_operating_states()
        self._outbox.release(self.time)
        if self.faults.crash_due(self.elapsed):
            self.log.record(self.elapsed, "fault", fault="crash")

    # ------------------------------------------------------------------ publishing
    def _publish_operating_state(self, name: str, cause: str = "", outcome: str = "") -> None:
        arm = self.arms[name]
        state = codec.OperatingState(self.now(), arm.state, arm.is_homed, arm.is_busy)
        self._outbox.send(
            self.now(),
            self.keys[name].operating_state,
            partial(codec.encode_operating_state, state),
            cause,
            outcome,
        )

    def _publish_operating_states(self) -> None:
        self._last_state_refresh = self.time
        for name in self.arms:
            self._publish_operating_state(name)

    def _publish_setpoint(self, name: str, jaw: bool) -> None:
        arm, keys, now = self.arms[name], self.keys[name], self.now()
        if jaw:
            self._outbox.send(
                now, keys.jaw_setpoint_js, JointStateMessage(now, arm.jaw.setpoint, names=JAW_JOINT_NAMES)
            )
        else:
            self._outbox.send(
                now, keys.setpoint_js, JointStateMessage(now, arm.joints.setpoint, names=ARM_JOINT_NAMES)
            )

    def _publish_state(self) -> None:
        """Every arm's state now. An arm's arrays are replaced each tick, never changed in place, so a
        message kept unencoded (nobody listens yet) still shows this instant when a late subscriber gets it."""
        now, send, joint_state = self.time, self._outbox.send, JointStateMessage
        for name, arm in self.arms.items():
            keys, joints, jaw = self.keys[name], arm.joints, arm.jaw
            send(
                now,
                keys.measured_js,
                joint_state(now, joints.encoder, joints.velocity, names=ARM_JOINT_NAMES),
            )
            send(
                now, keys.jaw_measured_js, joint_state(now, jaw.encoder, jaw.velocity, names=JAW_JOINT_NAMES)
            )
            send(now, keys.fiducial_js, joint_state(now, arm.physical, names=ARM_JOINT_NAMES))
            send(now, keys.measured_cp, partial(_encode_pose, now, joints.encoder, f"{name}_base"))
            self._publish_setpoint(name, jaw=False)
            self._publish_setpoint(name, jaw=True)

    def _publish_log_line(self, line: str) -> None:
        """A log entry on `sim/events`, to whoever listens: a message numbered for nobody would hold up the
        lockstep barrier of a client that subscribed later."""
        if self._recorder is not None:
            self._recorder.event(line)
        if self._events_outlet.matched:
            self._events_outlet.put(codec.encode_string(line))

    def _send_heartbeat(self) -> None:
        """Re-send each arm's latest state, unchanged, on its topics: a lockstep endpoint is seen alive
        while idle, late joiners see its state, and subscribers of claimed keys get it at this pace;
        faults are not drawn again, so what a client sees stays deterministic."""
        self._outbox.repeat(
            {key for keys in self.keys.values() for key in (*_state_keys(keys), keys.operating_state)}
        )

    def _capture(self, command_id: str) -> None:
        assert self.camera is not None and self.world is not None
        now = self.now()
        points, rgba = self.camera.capture_coloured(self.world, self.elapsed)
        assert self._scene is not None
        self._scene.log_events()
        encoded = partial(codec.encode_point_cloud, now, points, rgba=rgba)
        self._outbox.send(now, self.camera_keys.points, encoded, command_id, "done")

    # ------------------------------------------------------------------ shutdown
    def close(self) -> None:
        self._stop.set()
        with self._lock:  # no command callback is still publishing
            pass
        for declaration in self._declarations:
            declaration.undeclare()
        self._lockstep.close()
        self._outbox.close()
        self._events_outlet.close()
        self.log.close()


def _encode_pose(stamp: float, joints: NDArray[np.float64], frame_id: str) -> bytes:
    """`measured_cp`: the tip pose the encoders put the tool at, in the arm's base frame."""
    return codec.encode_pose_stamped(stamp, forward_kinematics(joints), frame_id)
