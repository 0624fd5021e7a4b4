"""The `robot` resource: both PSMs and the depth camera, and the run's clock; `--interface` picks the client.

`--interface pegbt` (the default): pegbt's own protocol over one zenoh link. `--endpoint auto` starts the
embedded simulator (`pegbt sim --lockstep --physics dvrk-real`; in real time, without `--lockstep`, when
the run asks for `--clock wall`) as a child process on a free loopback port; an address connects to a
simulator or a robot already running there. A simulator answers `sim/clock`: its ground truth
(`sim/truth`) judges the trial, and in lockstep its `SimClock` is the run's clock (time advances only when
the executive waits). A simulator in real time, and anything else (a robot, judged by what the executive
believes), runs on the wall clock.

`--interface dvrk`: any CRTK robot as a dVRK 2.x serves it through zenoh-bridge-ros2dds (`CrtkArm`,
`StreamingCamera`, trajectories streamed by a `Streamer` process), on the wall clock, never touching a
`sim/*` key; each arm enabled and homed before the tree starts; the robot's messages go to the tick log.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol

from pegbt.behaviours.resources.trial import Trial
from pegbt.clock import Clock, WallClock, is_realtime
from pegbt.errors import PegbtError
from pegbt.executive.providers import ProviderSetup
from pegbt.motion.robot_config import DEFAULT_TOOL, robot_arm_settings
from pegbt.numbers import checked_number
from pegbt.psm import ARMS
from pegbt.sim.log import read_sim_log
from pegbt.sim.process import SimProcess
from pegbt.sim.truth import ask_truth
from pegbt.transport import ArmClient, CameraClient, EndpointSilent, Link, SimClock, connect
from pegbt.transport.arm import LIVENESS_S as CLIENT_LIVENESS_S
from pegbt.transport.cloud_stream import CAPTURE_TIMEOUT, StreamingCamera
from pegbt.transport.crtk_arm import LIVENESS_S, CrtkArm, make_ready
from pegbt.transport.dvrk_topics import PsmTopics, point_cloud_topic
from pegbt.transport.endpoints import DEFAULT_POINTS_TOPIC
from pegbt.transport.keys import check_namespace
from pegbt.transport.ros2 import Ros2Wire, Topic
from pegbt.transport.session import Session, open_session, reaches_anyone
from pegbt.transport.streaming import Streamer
from pegbt.transport.wires import make_wire, wire_session_settings
from pegbt.transport.zivid_camera import CLOUD_GRACE_S, ZividCamera
from pegbt.transport.zivid_camera import POINTS_XYZRGBA as ZIVID_POINTS

SIMULATOR_PHYSICS = "dvrk-real"
SIMULATOR_ARGS = ("--physics", SIMULATOR_PHYSICS)
PROBE_TIMEOUT = 2.0  # s to wait for a simulator to answer `sim/clock` at an address (no answer: a robot)
# s to wait for a lockstep step: a backstop, never what decides a trial on a loaded machine (a camera capture
# on a loaded 2-core machine took over 2 s); a simulator that died is seen at once, its connection gone
STEP_TIMEOUT = 30.0
READY_TIMEOUT = 5.0  # s to wait for each arm's first state (a simulator we started: STEP_TIMEOUT, as a step)
WHAT_ANSWERS = {
    "bridge": "is zenoh-bridge-ros2dds running and listening there?",
    "rmw_zenoh": "is the ROS 2 graph's zenoh router (`ros2 run rmw_zenoh_cpp rmw_zenohd`) running there?",
}


class Truth(Protocol):
    """The simulator's log, as the judge reads it."""

    def entries(self, clock: Clock) -> list[dict[str, Any]]: ...


class SimulatorTruth:
    """The simulator's ground truth, for the judge only (behaviours know the world through camera and arms)."""

    def __init__(self, link: Link) -> None:
        self._link = link

    def entries(self, clock: Clock) -> list[dict[str, Any]]:
        """Every entry of the simulator's log so far (world events, injected faults), in order, each `time`
        on `clock` (the simulator logs seconds since it started)."""
        truth = ask_truth(self._link)
        offset = clock.now() - truth.time
        return [{**entry, "time": entry["time"] + offset} for entry in truth.log]


class SimulatorLogTruth:
    """A real-time simulator's ground truth read from the log file it writes, for the judge only: the
    dVRK interface serves no `sim/truth` (a robot has no oracle), so a trial against it is judged from
    the file, its times moved onto the wall clock by the epoch its `start` entry gives."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def entries(self, clock: Clock) -> list[dict[str, Any]]:
        entries = read_sim_log(self.path)
        start = next((entry for entry in entries if entry["kind"] == "start"), {})
        if not isinstance(start.get("epoch"), (int, float)):
            raise PegbtError(
                "the simulator's log has no start entry with its epoch: not a real-time `pegbt sim "
                "--interface dvrk` log",
                file=self.path,
                field="simlog",
            )
        return [{**entry, "time": entry["time"] + start["epoch"]} for entry in entries]


class Robot:
    """Arms, camera and clock of one run; `trial` records the transfers for the judge."""

    def __init__(
        self,
        arms: dict[str, Any],
        camera: Any,
        clock: Clock,
        *,
        link: Link | None = None,
        simulator: SimProcess | None = None,
        lockstep: bool = False,
        truth: Truth | None = None,
        endpoint: str = "",
        closers: tuple[Callable[[], None], ...] = (),
        messages: tuple[Callable[[], list[dict[str, Any]]], ...] = (),
    ) -> None:
        """`arms` (`ArmClient`s or `CrtkArm`s by name) and `camera` share the verbs behaviours use; `closers`
        run at `close()`, in order, after the link is closed; `messages` are further sources of tick-log
        messages besides the arms (a servo streamer's stalls)."""
        self.link = link
        self.run_clock = clock if lockstep else None  # a lockstep simulator's clock drives the run
        self.simulator = simulator
        self.lockstep = lockstep
        self.truth = truth
        self.endpoint = endpoint
        self.arms = arms
        self.camera = camera
        self.trial = Trial(clock, truth)
        self._closers = closers
        self._message_sources = messages
        self.wire: Ros2Wire | None = None  # a CRTK robot's wire, and the topics a recording takes from it
        self.ros2_topics: tuple[Topic, ...] = ()

    def arm(self, name: str) -> Any:
        if name not in self.arms:
            raise PegbtError(f"unknown arm {name!r}; known: {', '.join(self.arms)}", field="arm")
        return self.arms[name]

    def wait_until_ready(self, timeout: float = READY_TIMEOUT) -> None:
        for arm in self.arms.values():
            arm.wait_until_ready(timeout)

    def log_messages(self) -> list[dict[str, Any]]:
        """The robot's error, warning and status messages since the last call (for the tick log), then those
        of the other sources."""
        sources = [getattr(arm, "drain_messages", list) for arm in self.arms.values()]
        return [message for source in (*sources, *self._message_sources) for message in source()]

    def report(self) -> Any:
        """The judged trial (None when the tree moved no block)."""
        return self.trial.result() if self.trial.transfers else None

    def progress(self) -> Any:
        return self.trial.progress_listener()

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
        for close in self._closers:
            close()
        if self.simulator is not None:
            self.simulator.stop()


def simulated_world(
    options: Mapping[str, Any], clock: str | None, started: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """What a tick log's header records of the world a run meets (`RunOptions.world`): for a simulator
    started for the run (`--endpoint auto` with pegbt's interface, as `options` say; or one the caller
    started, with the `seed`, `faults` and `world-effects` of `started`), its physics, speed (lockstep, or
    real time with `--clock`), seed, fault plan and world file; nothing for an endpoint at an address (a
    robot, or a simulator that knows its own)."""
    embedded = options.get("interface", "pegbt") == "pegbt" and options.get("endpoint", "auto") == "auto"
    if not embedded and started is None:
        return {}
    given = options if started is None else started
    return {
        "simulator": "embedded" if embedded else "pegbt sim",
        "physics": SIMULATOR_PHYSICS,
        "speed": "lockstep" if clock is None else "real time",
        "seed": int(given.get("seed") or 0),
        "faults": given.get("faults"),
        "world_effects": given.get("world-effects"),
    }


def _probe_simulator(link: Link) -> SimClock | None:
    """The simulator's clock if a simulator answers at the other end of `link`, else None (a robot). Only
    the probe is short: a step (a camera capture, say) may take longer on a busy machine."""
    try:
        return SimClock(link, reply_timeout=STEP_TIMEOUT, probe_timeout=PROBE_TIMEOUT)
    except PegbtError:
        return None


def connect_robot(
    endpoint: str,
    seed: int = 0,
    faults: str | None = None,
    simlog: str | None = None,
    wall_clock: Clock | None = None,
    world_effects: str | None = None,
) -> Robot:
    """A `Robot` on `endpoint` (`auto`: a fresh embedded simulator seeded with `seed`, injecting the fault
    plan `faults` if given, adding the world file's `world_effects` if given, appending its log to
    `simlog` if given). With `wall_clock` (a clock in real time) the embedded simulator runs in real time
    and a simulator at an address must too; without it, a robot or a simulator in real time runs on a new
    `WallClock`."""
    for value, flag, sim_flag in (
        (faults, "--faults", "--faults"),
        (simlog, "--simlog", "--log"),
        (world_effects, "--world-effects", "--world-effects"),
    ):
        if value is not None and endpoint != "auto":
            raise PegbtError(
                f"{flag} is for the embedded simulator (--endpoint auto); give `pegbt sim {sim_flag}` to a "
                "simulator you start yourself",
                field=flag,
            )
    simulator = None
    if endpoint == "auto":
        simulator = SimProcess(
            [
                *SIMULATOR_ARGS,
                *([] if wall_clock is not None else ["--lockstep"]),
                "--seed",
                str(seed),
                *(["--faults", faults] if faults else []),
                *(["--world-effects", world_effects] if world_effects else []),
                *(["--log", simlog] if simlog else []),
            ]
        )
    try:
        link = connect([simulator.endpoint if simulator else endpoint])
        try:
            # the simulator we started must answer, however busy the machine: no probe timeout for it
            sim_clock = (
                SimClock(link, reply_timeout=STEP_TIMEOUT)
                if simulator is not None
                else _probe_simulator(link)
            )
            truth = SimulatorTruth(link) if sim_clock is not None else None
            lockstep = bool(sim_clock and sim_clock.lockstep)
            if lockstep and wall_clock is not None:
                raise PegbtError(
                    f"the simulator at {endpoint} runs in lockstep, and its clock drives the run: drop "
                    "--clock, or start `pegbt sim` without --lockstep",
                    field="--clock",
                )
            clock = sim_clock if lockstep and sim_clock is not None else wall_clock or WallClock()
            # a simulator in real time, on the wall clock, keeps its own liveness timeout: a busy machine
            # starves its process for longer than a robot's 0.2 s
            liveness = CLIENT_LIVENESS_S["simulator"] if truth is not None else None
            robot = Robot(
                {name: ArmClient(link, name, clock=clock, liveness_timeout=liveness) for name in ARMS},
                CameraClient(link, clock=clock),
                clock,
                link=link,
                simulator=simulator,
                truth=truth,
                lockstep=lockstep,
                endpoint=endpoint,
            )
            try:
                robot.wait_until_ready(STEP_TIMEOUT if simulator is not None else READY_TIMEOUT)
            except EndpointSilent as error:
                where = simulator.endpoint if simulator else endpoint
                raise EndpointSilent(
                    f"no endpoint answered at {where}: {error.message}", field=error.field
                ) from None
        except BaseException:
            link.close()
            raise
    except BaseException:
        if simulator is not None:
            simulator.stop()
        raise
    return robot


def connect_crtk_robot(
    endpoint: str,
    namespace: str = "",
    robot_config: str | None = None,
    robot_tool: str = DEFAULT_TOOL,
    camera: str = DEFAULT_POINTS_TOPIC,
    liveness: float = LIVENESS_S,
    ros2: str = "bridge",
    simlog: str | None = None,
    camera_kind: str = "stream",
    speed: float = 1.0,
) -> Robot:
    """A `Robot` of CRTK arms at `endpoint` (a zenoh-bridge-ros2dds, a `pegbt sim --interface dvrk`), its
    arms enabled and homed, limits narrowed by the dVRK's `robot_config` folder when given; its camera
    streams on the topic `camera`, or for `camera_kind` zivid is a Zivid driver's capture service; the jaw's
    streamed ramps at `speed` of its velocity (`ArmSettings.at_speed`)."""
    if endpoint == "auto":
        raise PegbtError(
            "--interface dvrk talks to a robot: give its bridge's address (--endpoint tcp/HOST:PORT)",
            field="--endpoint",
        )
    check_namespace(namespace, "--namespace")
    speed = checked_number(speed, "--speed", above=0.0, at_most=1.0)
    settings = {arm: robot_arm_settings(arm, robot_config, robot_tool).at_speed(speed) for arm in ARMS}
    period = min(arm.control_period for arm in settings.values())
    session = open_session(wire_session_settings(ros2, [endpoint]))
    try:
        _await_anyone(session, endpoint, ros2)
        streamer = Streamer([endpoint], namespace, settings, period, ros2=ros2)
    except BaseException:
        session.close()
        raise
    try:
        wire = make_wire(ros2, session, namespace, node_name="pegbt")
        clock = WallClock()
        arms = {
            arm: CrtkArm(
                wire, arm, settings=settings[arm], streamer=streamer, clock=clock, liveness_timeout=liveness
            )
            for arm in ARMS
        }
        depth_camera: StreamingCamera | ZividCamera = (
            ZividCamera(wire, clock=clock, grace=max(CLOUD_GRACE_S, liveness))
            if camera_kind == "zivid"
            else StreamingCamera(
                wire, point_cloud_topic(camera), clock=clock, timeout=max(CAPTURE_TIMEOUT, liveness)
            )
        )
        robot = Robot(
            arms,
            depth_camera,
            clock,
            endpoint=endpoint,
            truth=SimulatorLogTruth(simlog) if simlog else None,
            closers=(streamer.close, session.close),
            messages=(streamer.drain_messages,),
        )
        robot.wire = wire  # what a recording listens to (`pegbt run --record`)
        robot.ros2_topics = (
            *(topic for arm in ARMS for topic in (*PsmTopics(arm).published(), *PsmTopics(arm).subscribed())),
            *((ZIVID_POINTS,) if camera_kind == "zivid" else (point_cloud_topic(camera),)),
        )
        try:
            robot.wait_until_ready()
        except EndpointSilent as error:
            raise _robot_silent(error, session, endpoint, ros2, namespace) from None
        make_ready(list(arms.values()), speed=speed)
    except BaseException:
        streamer.close()
        session.close()
        raise
    return robot


def _await_anyone(session: Session, endpoint: str, ros2: str) -> None:
    """Return once `session` reaches a bridge or router at `endpoint` (zenoh connects while the session
    opens, and retries in the background); `EndpointSilent` naming what should listen there if none comes
    within `READY_TIMEOUT`, before a servo streamer is started for a robot nobody serves."""
    deadline = time.monotonic() + READY_TIMEOUT
    while not reaches_anyone(session):
        if time.monotonic() > deadline:
            raise EndpointSilent(
                f"nobody connected within {READY_TIMEOUT:g} s; nothing answers at {endpoint}: "
                f"{WHAT_ANSWERS[ros2]}",
                field="--endpoint",
            )
        time.sleep(0.05)


def _robot_silent(
    error: EndpointSilent, session: Session, endpoint: str, ros2: str, namespace: str
) -> EndpointSilent:
    """`error` with why the robot sent nothing: nobody at `endpoint` (no bridge, no router); its joints but
    not its latched `operating_state` (a bridge that keeps latched topics where pegbt's late joiner cannot
    ask for them); or somebody there but none of the arm's topics under `namespace` (the robot's system
    down, another namespace)."""
    if not reaches_anyone(session):
        why = f"nothing answers at {endpoint}: {WHAT_ANSWERS[ros2]}"
    elif (error.field or "").endswith("/operating_state"):
        why = "its joints come, but not its latched operating_state (sent only when it changes)" + (
            ": a bridge must be zenoh-bridge-ros2dds 1.5.1 or later, which serves latched topics to late "
            "joiners from zenoh-ext advanced publishers (zenoh-plugin-ros2dds #524; before, a PublicationCache)"
            if ros2 == "bridge"
            else ""
        )
    else:
        under = f"under namespace {namespace!r}" if namespace else "without a namespace"
        why = (
            f"{endpoint} answers, but no robot topic comes {under}: is the robot's ROS 2 system running, "
            "and is --namespace the one its topics have?"
        )
    return EndpointSilent(f"{error.message}; {why}", field=error.field)


def provide_robot(setup: ProviderSetup) -> Robot:
    """The `robot` resource for `pegbt run` (options `interface`, `endpoint`, `seed`, `faults`,
    `world-effects`, `simlog`; for `dvrk` also `namespace`, `ros2`, `robot-config`, `robot-tool`, `camera`,
    `camera-topic`, `speed`). `--clock` may only
    ask for a clock in real time (the robot's time passes on its own): `--clock wall` runs the embedded
    simulator in real time."""
    options = setup.options
    if setup.clock_name is not None and not is_realtime(setup.clock):
        raise PegbtError(
            f"a robot or a simulator cannot run on the {setup.clock_name} clock: their time passes on its "
            "own (--clock wall runs in real time; without --clock the embedded simulator runs in lockstep)",
            field="--clock",
        )
    if options.get("interface") == "dvrk":
        for name in ("faults", "world-effects"):
            if options.get(name) is not None:
                raise PegbtError(
                    f"--{name} is for the embedded simulator (--interface pegbt); give it to `pegbt sim "
                    f"--{name}`",
                    field=f"--{name}",
                )
        return connect_crtk_robot(
            str(options.get("endpoint") or "auto"),
            str(options.get("namespace") or ""),
            options.get("robot-config"),
            str(options.get("robot-tool") or DEFAULT_TOOL),
            str(options.get("camera-topic") or DEFAULT_POINTS_TOPIC),
            checked_number(float(options.get("liveness") or LIVENESS_S), "--liveness", above=0.0),
            ros2=str(options.get("ros2") or "bridge"),
            simlog=options.get("simlog"),
            camera_kind=str(options.get("camera") or "stream"),
            speed=1.0 if options.get("speed") is None else float(options["speed"]),
        )
    return connect_robot(
        str(options.get("endpoint") or "auto"),
        int(options.get("seed") or 0),
        options.get("faults"),
        options.get("simlog"),
        setup.clock if setup.clock_name is not None else None,
        options.get("world-effects"),
    )
