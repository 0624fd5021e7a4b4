"""`pegbt sim`: run the simulator endpoint until interrupted (or until an injected crash)."""

from __future__ import annotations

import argparse
import dataclasses
import gc
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.bagoptions import add_record_arguments
from pegbt.errors import PegbtError
from pegbt.numbers import NumberOption
from pegbt.scheduling import ROBOT_PRIORITY, realtime_priority
from pegbt.sim.process import SERVING_PREFIX, STAGE_PREFIX
from pegbt.simoptions import add_sim_world_arguments, refuse_dvrk_only
from pegbt.transport.endpoints import DEFAULT_ENDPOINT, DEFAULT_POINTS_TOPIC

if TYPE_CHECKING:
    import zenoh

    from pegbt.sim.camera import DepthCamera
    from pegbt.sim.dvrk_endpoint import DvrkEndpoint
    from pegbt.sim.endpoint import SimEndpoint
    from pegbt.sim.fault_plan import FaultPlan
    from pegbt.sim.world import World
    from pegbt.transport.recorder import WireRecorder
    from pegbt.transport.session import SessionSettings

CRASH_EXIT_STATUS = 3
CONNECT_GRACE = 3.0  # s after start-up before saying that nothing answers where the simulator connects


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sim",
        help="run the simulator endpoint (two PSMs, the pegboard world and a depth camera over zenoh)",
        description="Serve two simulated PSMs, the FLS pegboard world they act in and its depth camera over zenoh, "
        "with dVRK CRTK topic names and CDR payloads. "
        f"Listens on {DEFAULT_ENDPOINT} (peer mode, no scouting) unless told otherwise.",
    )
    parser.add_argument(
        "--listen",
        action="append",
        metavar="ENDPOINT",
        help=f"zenoh listen endpoint (default {DEFAULT_ENDPOINT}; repeatable)",
    )
    parser.add_argument(
        "--allow-remote-listen",
        action="store_true",
        help="let --listen name a non-loopback address (peers on that network can then command the arms)",
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint to connect to (a router, a bridge; repeatable)",
    )
    parser.add_argument(
        "--interface",
        choices=("pegbt", "dvrk"),
        default="pegbt",
        help="pegbt: CRTK topics with pegbt's extensions (follow_jt, sim/*, lockstep; the default); "
        "dvrk: only what a dVRK 2.x PSM serves through zenoh-bridge-ros2dds, in real time",
    )
    parser.add_argument("--namespace", default="", help="key prefix, e.g. lab2 for lab2/PSM1/measured_js")
    parser.add_argument(
        "--ros2",
        choices=("bridge", "rmw_zenoh"),
        default="bridge",
        help="--interface dvrk: the ROS 2 wire: bridge (zenoh-bridge-ros2dds's keys; the default) or "
        "rmw_zenoh (a node of a ROS 2 graph on rmw_zenoh: its keys, attachments and liveliness tokens; "
        "--connect names the graph's zenoh router)",
    )
    parser.add_argument(
        "--physics", default="ideal", help="cable physics: ideal, dvrk-real, or a preset/report JSON file"
    )
    parser.add_argument(
        "--lockstep", action="store_true", help="advance time only when a client's SimClock steps it"
    )
    parser.add_argument(
        "--world",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="simulate the pegboard, blocks and depth camera (default); --no-world: arms only",
    )
    parser.add_argument(
        "--faults",
        type=Path,
        metavar="YAML",
        help="fault plan (loss, latency, crash, world and camera faults)",
    )
    add_sim_world_arguments(parser)
    parser.add_argument(
        "--seed",
        action=NumberOption,
        type=int,
        at_least=0,
        help="seed of the block layout, depth noise and injected faults (default: the plan's, else 0)",
    )
    parser.add_argument(
        "--loss",
        action=NumberOption,
        at_least=0.0,
        at_most=1.0,
        metavar="P",
        help="probability of losing each stream message",
    )
    parser.add_argument(
        "--latency",
        action=NumberOption,
        at_least=0.0,
        metavar="S",
        help="extra latency of stream messages (s)",
    )
    parser.add_argument(
        "--crash-at",
        action=NumberOption,
        at_least=0.0,
        metavar="T",
        help="crash the endpoint at simulated time T (s)",
    )
    parser.add_argument(
        "--log", type=Path, metavar="JSONL", help="append the simulator's log (world events, faults) here"
    )
    parser.add_argument(
        "--camera-topic",
        default=DEFAULT_POINTS_TOPIC,
        metavar="TOPIC",
        help=f"--interface dvrk: the ROS 2 topic of the camera's PointCloud2 stream (default {DEFAULT_POINTS_TOPIC})",
    )
    parser.add_argument(
        "--camera-rate",
        action=NumberOption,
        default=10.0,
        above=0.0,
        at_most=30.0,
        metavar="HZ",
        help="--interface dvrk: point clouds per second (default 10)",
    )
    parser.add_argument(
        "--state-rate",
        action=NumberOption,
        default=100.0,
        above=0.0,
        at_most=100.0,
        metavar="HZ",
        help="--interface dvrk: joint and Cartesian states per second (default 100, the dVRK's ROS period)",
    )
    parser.add_argument(
        "--stop-with-parent",
        action="store_true",
        help="stop when standard input closes: a parent process that pipes it is gone (even killed)",
    )
    parser.add_argument(
        "--report-stages",
        action="store_true",
        help="print each start-up stage reached on standard output before the serving line, for a parent "
        "that bounds the start-up by its progress (as `SimProcess` does on a loaded machine)",
    )
    parser.add_argument(
        "--priority",
        choices=("realtime", "normal"),
        default="realtime",
        help="real time only: run under SCHED_FIFO where the system permits it, above pegbt's servo streamer, "
        "as a dVRK's controller runs, so that a busy machine delays the client and not the simulated "
        "robot (default realtime; normal: the ordinary scheduler)",
    )
    add_record_arguments(parser)
    parser.set_defaults(handler=_sim)


def _sim(args: argparse.Namespace) -> int:
    from pegbt.sim.fault_plan import FaultPlan
    from pegbt.transport.keys import check_namespace
    from pegbt.transport.session import endpoint_settings

    _stage(args, "started")
    check_namespace(args.namespace, "--namespace")
    if args.interface == "dvrk":
        _refuse_pegbt_only_options(args)
    else:
        refuse_dvrk_only(args)
    if args.ros2 == "rmw_zenoh":
        settings = _graph_settings(args)
    else:
        listen = args.listen or [DEFAULT_ENDPOINT]
        settings = endpoint_settings(listen, args.connect, args.allow_remote_listen)
    plan = FaultPlan.load(args.faults) if args.faults else FaultPlan()
    overrides = {
        "seed": args.seed,
        "loss_probability": args.loss,
        "latency": args.latency,
        "crash_at": args.crash_at,
    }
    plan = dataclasses.replace(plan, **{k: v for k, v in overrides.items() if v is not None})
    if args.world_effects is not None and not args.world:
        raise PegbtError("--world-effects act on the world: drop --no-world", field="--world-effects")
    world, camera = _world(args, plan) if args.world else (None, None)
    # before the session opens, so that zenoh's threads inherit it
    wanted = not args.lockstep and args.priority == "realtime"
    with realtime_priority(ROBOT_PRIORITY if wanted else None) as realtime:
        return _serve(args, settings, plan, world, camera, realtime)


def _serve(
    args: argparse.Namespace,
    settings: SessionSettings,
    plan: FaultPlan,
    world: World | None,
    camera: DepthCamera | None,
    realtime: bool,
) -> int:
    """Open the session and serve until stopped; the process ends here (`os._exit`) unless refused."""
    from pegbt.transport.session import open_session

    session = open_session(settings)
    try:
        _stage(args, "session open")
        endpoint = (_dvrk_endpoint if args.interface == "dvrk" else _pegbt_endpoint)(
            args, plan, session, world, camera
        )
        _stage(args, "endpoint built")
    except BaseException:
        session.close()
        raise
    recorder = None
    outcome = "stopped"
    try:  # from here a stop (Ctrl-C, SIGTERM) at any moment ends in the orderly close below
        recorder = _recorder(args, endpoint) if args.record else None
        signal.signal(signal.SIGTERM, lambda *_: endpoint.stop())
        if args.stop_with_parent:
            threading.Thread(
                target=_stop_at_stdin_eof, args=(endpoint,), name="parent-watch", daemon=True
            ).start()
        _announce(args, settings, endpoint, realtime, plan, world)
        if args.connect:
            threading.Thread(
                target=_warn_if_unconnected, args=(session, args.connect), name="connect-watch", daemon=True
            ).start()
        gc.collect()
        gc.freeze()  # what start-up built (modules, meshes) lives on: a collection scanning it would stall a tick
        outcome = endpoint.run()
    except KeyboardInterrupt:
        pass
    except BaseException:  # refused (a recording it cannot write): closed here, raised to the caller
        endpoint.close()
        session.close()
        raise
    _quit_on_the_next_stop()
    if recorder is not None:
        try:
            recorder.close()
        except PegbtError as error:  # the simulator still stops in order
            print(f"pegbt sim: {error}", file=sys.stderr, flush=True)
    if outcome == "crashed":
        print(f"pegbt sim: injected crash at t={endpoint.elapsed:.3f} s", file=sys.stderr, flush=True)
        endpoint.log.close()
        os._exit(CRASH_EXIT_STATUS)  # die like a crash: no orderly goodbye to the peers
    endpoint.close()
    session.close()
    # Everything is closed and written. Leave now: after a peer vanished mid-step, a zenoh callback thread
    # can outlive its session, and the interpreter's exit would wait on it for ever (seen in eval runs).
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _warn_if_unconnected(session: zenoh.Session, connect: list[str]) -> None:
    """Say once on stderr if nothing answers where the simulator connects (a ROS 2 graph's router, a bridge):
    zenoh keeps trying in silence, and no client reaching the graph would ever see the arms."""
    import zenoh

    from pegbt.transport.session import reaches_anyone

    time.sleep(CONNECT_GRACE)
    try:
        if reaches_anyone(session):
            return
    except zenoh.ZError:  # the simulator stopped meanwhile
        return
    print(
        f"pegbt sim: nothing answers at {', '.join(connect)} (zenoh keeps trying): is the router or bridge "
        "running there?",
        file=sys.stderr,
        flush=True,
    )


def _recorder(args: argparse.Namespace, endpoint: SimEndpoint | DvrkEndpoint) -> WireRecorder:
    """A recorder of everything the simulator takes and sends, on its clock (simulated in lockstep)."""
    from pegbt.sim.endpoint import SimEndpoint
    from pegbt.transport.recorder import WireRecorder

    assert isinstance(endpoint, SimEndpoint)  # `_refuse_pegbt_only_options` refused --record with the dVRK's

    kind = "simulator (lockstep)" if args.lockstep else "simulator (real time)"
    recorder = WireRecorder(
        args.record,
        lambda: endpoint.time,
        simulated=args.lockstep,
        clock_kind=kind,
        cloud_step=args.record_cloud_step,
    )
    endpoint.record(recorder)
    return recorder


def _announce(
    args: argparse.Namespace,
    settings: SessionSettings,
    endpoint: SimEndpoint | DvrkEndpoint,
    realtime: bool,
    plan: FaultPlan,
    world: World | None,
) -> None:
    """The line a user (and `SimProcess`) waits for: what is served, where, how."""
    mode = "lockstep" if args.lockstep else "real time" + (", SCHED_FIFO" if realtime else "")
    where = (
        f"the ROS 2 graph of router {', '.join(args.connect)} (rmw_zenoh)"
        if args.ros2 == "rmw_zenoh"
        else ", ".join(settings.listen)
    )
    scene = "no world"
    if world is not None:
        effects = ", ".join(effect.kind for effect in world.effects) or "none"
        scene = f"world and camera, seed {plan.seed}, world effects: {effects}"
    print(
        f"{SERVING_PREFIX} {', '.join(endpoint.arms)} on {where} ({mode}, {args.interface} "
        f"interface, physics {args.physics}, {scene})",
        flush=True,
    )


def _stage(args: argparse.Namespace, stage: str) -> None:
    """With --report-stages, say that start-up reached `stage`: each line restarts its parent's bound."""
    if args.report_stages:
        print(f"{STAGE_PREFIX}{stage}", flush=True)


def _quit_on_the_next_stop() -> None:
    """From here the simulator closes in order; a second Ctrl-C or SIGTERM (a user who will not wait, a
    `timeout` that signals the process and then its group) quits at once. Raised as an exception in the
    middle of closing, it left the zenoh session open and the interpreter waiting on its threads for ever."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda number, _: os._exit(128 + number))


def _stop_at_stdin_eof(endpoint: SimEndpoint | DvrkEndpoint) -> None:
    """Block until standard input ends, then stop: a parent that died, however, closed its end of the pipe."""
    while sys.stdin.buffer.read(4096):
        pass
    endpoint.stop()


def _world(args: argparse.Namespace, plan: FaultPlan) -> tuple[World, DepthCamera]:
    """The pegboard world and its camera (a Zivid 2's whole image for `--camera zivid`), seeded and faulted as
    the plan says, with the world file's effects (`--world-effects`)."""
    from pegbt.sim.camera import DepthCamera

    _stage(args, "camera library loaded")  # open3d: the longest import of a start-up
    from pegbt.sim.world import World
    from pegbt.sim.world_effects import WorldEffects, read_world_file

    effects = WorldEffects() if args.world_effects is None else read_world_file(args.world_effects)
    world = World(plan.seed, faults=plan.world, effects=effects)
    _stage(args, "world built")
    if args.camera == "zivid":
        from pegbt.sim.zivid import zivid2_model

        model = zivid2_model(world.cell.camera)
        return world, DepthCamera(seed=plan.seed, faults=plan.camera, model=model, full_frame=True)
    return world, DepthCamera(seed=plan.seed, faults=plan.camera)


def _graph_settings(args: argparse.Namespace) -> SessionSettings:
    """A node of a ROS 2 graph on rmw_zenoh: it connects to the graph's router and listens where gossip
    tells its peers, so `--listen` has no place; only the dVRK interface is a ROS 2 robot's."""
    from pegbt.transport.wires import wire_session_settings

    if args.interface != "dvrk":
        raise PegbtError("--ros2 rmw_zenoh serves the dVRK's interface: add --interface dvrk", field="--ros2")
    if args.listen:
        raise PegbtError(
            "--ros2 rmw_zenoh joins the graph through its router (--connect); drop --listen", field="--listen"
        )
    return wire_session_settings("rmw_zenoh", args.connect)


def _refuse_pegbt_only_options(args: argparse.Namespace) -> None:
    """The dVRK interface is a robot's: real time, and no network faults of pegbt's own transport."""
    from pegbt.errors import PegbtError

    if args.lockstep:
        raise PegbtError(
            "the dVRK interface runs in real time only, as a dVRK does; drop --lockstep or use "
            "--interface pegbt",
            field="--lockstep",
        )
    if args.record:
        raise PegbtError(
            "--record is pegbt's interface's; to record a dVRK interface, record on the client "
            "(pegbt run --record) or with ros2 bag record",
            field="--record",
        )
    for option, value in (("--loss", args.loss), ("--latency", args.latency), ("--crash-at", args.crash_at)):
        if value is not None:
            raise PegbtError(
                f"{option} acts on pegbt's own transport: use it with --interface pegbt", field=option
            )


def _pegbt_endpoint(
    args: argparse.Namespace,
    plan: FaultPlan,
    session: zenoh.Session,
    world: World | None,
    camera: DepthCamera | None,
) -> SimEndpoint:
    from pegbt.sim.endpoint import EndpointConfig, SimEndpoint

    config = EndpointConfig(
        physics=args.physics, lockstep=args.lockstep, namespace=args.namespace, faults=plan, log_path=args.log
    )
    return SimEndpoint(session, config, world=world, camera=camera)


def _dvrk_endpoint(
    args: argparse.Namespace,
    plan: FaultPlan,
    session: zenoh.Session,
    world: World | None,
    camera: DepthCamera | None,
) -> DvrkEndpoint:
    from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig
    from pegbt.transport.wires import make_wire

    config = DvrkEndpointConfig(
        physics=args.physics,
        log_path=args.log,
        state_period=1.0 / args.state_rate,
        camera_topic=args.camera_topic,
        camera_period=1.0 / args.camera_rate,
        camera=args.camera,
        robot_clock_offset=args.robot_clock_offset,
    )
    wire = make_wire(args.ros2, session, args.namespace, node_name="pegbt_sim")
    return DvrkEndpoint(wire, config, world=world, camera=camera)
