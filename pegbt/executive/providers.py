"""Where `pegbt run` gets its clock, the resources a tree's behaviours declare, and the options they read.

Packages register here, so that adding a resource never edits the run command:

- `RESOURCE_PROVIDERS`: a provider per resource name (`"robot": "pegbt.behaviours.resources.robot:provide_robot"`).
  A provider is called once per run with a `ProviderSetup` (the run's options and clock) and returns
  the resource. Providers are imported only when a tree needs them.
- `RUN_OPTIONS`: the options providers read; `pegbt run` offers each as `--NAME` and hands every
  provider all of them (a provider ignores those it does not know).
- `CLOCKS`: clocks by name, for `--clock`.

A resource may take part in the run beyond serving its behaviours (each is optional):

- `run_clock`: a resource that is itself the time source (a simulator in lockstep) supplies the run's clock;
- `progress()`, `report()`, `log_messages()`: the hooks declared below (`ShowsProgress`, `Reports`,
  `LogsMessages`), which a resource follows by having the method;
- `close()`: called at the end of the run, always.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from pegbt.clock import Clock
from pegbt.errors import PegbtError
from pegbt.runconditions import CONDITIONS, PROTOCOLS


@runtime_checkable
class ShowsProgress(Protocol):
    """A resource with a progress display of its own (the trial's transfers), shown instead of the tick bar
    unless the run is quiet."""

    def progress(self) -> Callable[[dict[str, Any]], None]:
        """A tick-log listener that shows the run's progress."""
        ...


@runtime_checkable
class Reports(Protocol):
    """A resource with a result to print after the run, asked while it is still open."""

    def report(self) -> Any:
        """The result (None: nothing to report); one whose `ok` is False makes the run exit non-zero."""
        ...


@runtime_checkable
class LogsMessages(Protocol):
    """A resource that hears messages (a robot's errors and warnings), logged and shown as the run goes."""

    def log_messages(self) -> list[dict[str, Any]]:
        """What it heard since it was last asked, as tick-log `message` records (`source`, `level`, `text`,
        `stamp`)."""
        ...


CLOCKS: dict[str, str] = {
    "wall": "pegbt.clock:WallClock",
    "manual": "pegbt.clock:ManualClock",
}
RESOURCE_PROVIDERS: dict[str, str] = {
    "robot": "pegbt.behaviours.resources.robot:provide_robot",
    "skills": "pegbt.behaviours.resources.skills:provide_skills",
}


@dataclass(frozen=True)
class RunOption:
    """An option of `pegbt run` (`--NAME VALUE`) that providers read."""

    name: str
    help: str
    default: Any = None
    type: type = str
    choices: tuple[Any, ...] = ()


RUN_OPTIONS: dict[str, RunOption] = {
    option.name: option
    for option in (
        RunOption(
            "endpoint",
            "robot: `auto` starts the embedded simulator (lockstep, dvrk-real physics, --interface pegbt); "
            "or the zenoh address of a running simulator or robot, e.g. tcp/127.0.0.1:7447",
            "auto",
        ),
        RunOption(
            "interface",
            "robot: pegbt (pegbt's simulator: lockstep, whole trajectories on follow_jt) or dvrk (any CRTK "
            "robot as a dVRK 2.x is reached through zenoh-bridge-ros2dds: wall clock, trajectories streamed "
            "as servo_jp by a streamer process; needs --endpoint ADDRESS)",
            "pegbt",
            choices=("pegbt", "dvrk"),
        ),
        RunOption("namespace", "robot: the key prefix of the robot's topics (the bridge's namespace)", ""),
        RunOption(
            "ros2",
            "robot (--interface dvrk): the ROS 2 wire: bridge (zenoh-bridge-ros2dds; --endpoint is the "
            "bridge) or rmw_zenoh (a node of a ROS 2 graph on rmw_zenoh; --endpoint is its zenoh router)",
            "bridge",
            choices=("bridge", "rmw_zenoh"),
        ),
        RunOption(
            "robot-config",
            "robot and skills: the dVRK's share/ folder; its kinematic/PSM.json and tool file narrow the "
            "joint limits of skills/psm.yaml",
        ),
        RunOption(
            "robot-tool",
            "robot and skills: the tool file in the dVRK's share/tool/, without .json "
            "(None: LARGE_NEEDLE_DRIVER_400006)",
        ),
        RunOption(
            "liveness",
            "robot (--interface dvrk): seconds without the robot's measured_js before the run stops, and "
            "that a streaming camera may take to answer a capture, at least 2 (None: 1; a simulator sharing "
            "a loaded machine may need more)",
            type=float,
        ),
        RunOption(
            "camera",
            "robot (--interface dvrk): the depth camera's ROS 2 driver: stream (a camera that streams "
            "PointCloud2 on --camera-topic, as realsense2_camera does) or zivid (zivid_camera: pegbt calls its "
            "/capture service for each cloud and thins the full-resolution cloud on /points/xyzrgba)",
            "stream",
            choices=("stream", "zivid"),
        ),
        RunOption(
            "camera-topic",
            "robot (--interface dvrk): the streaming PointCloud2 topic of the depth camera "
            "(None: /camera/camera/depth/color/points, a RealSense's)",
        ),
        RunOption(
            "condition",
            "skills: uncalibrated (cubic motion), calibrated (cubic + compensation), "
            "optimized (spline + SQP + compensation)",
            "optimized",
            choices=CONDITIONS,
        ),
        RunOption(
            "protocol",
            "skills and tree: pegbt (the trees' recovery and heights) or paper (the reference paper's: one "
            "attempt per block, the arms registered to the camera as its were, and with cubic motions the "
            "carry stopped at its height over the goal peg to look at the held block before lowering it, and "
            "the block a giver holds out looked at before the receiver takes it where it is seen)",
            "pegbt",
            choices=PROTOCOLS,
        ),
        RunOption(
            "speed",
            "skills and robot: move at this fraction (0, 1] of the planner's speed, for a first run on a "
            "robot: velocities × F, accelerations × F², every motion 1/F as long (None: 1)",
            type=float,
        ),
        RunOption("seed", "robot: seed of the embedded simulator's world", 0, type=int),
        RunOption(
            "faults",
            "robot: fault plan (YAML) for the embedded simulator to inject (see `pegbt sim --faults`)",
        ),
        RunOption(
            "world-effects",
            "robot: world file (YAML) of the world effects the embedded simulator adds (see `pegbt sim "
            "--world-effects`)",
        ),
        RunOption(
            "simlog",
            "robot: file the embedded simulator appends its log to: injected faults and world events, "
            "the ground truth (see `pegbt sim --log`); with --interface dvrk, the log file of the "
            "simulator at --endpoint, which then judges the trial",
        ),
        RunOption(
            "calibration",
            "skills: directory of calibration models (default: the simulator's for "
            "--endpoint auto, else skills/calibration)",
        ),
    )
}


@dataclass(frozen=True)
class ProviderSetup:
    """What a provider receives: the run's options (every `RUN_OPTIONS` name, defaults filled in), its clock
    and the clock's name if `--clock` asked for one (None: the default, or whatever a resource supplies),
    and the run's variant (the paper's protocol places each variant at its own height)."""

    clock: Clock
    options: Mapping[str, Any] = field(default_factory=dict)
    clock_name: str | None = None
    variant: str = ""


def _load(target: str) -> Any:
    module_name, attribute = target.split(":")
    return getattr(importlib.import_module(module_name), attribute)


def make_clock(name: str) -> Clock:
    """The clock registered as `name` (a `PegbtError` naming the choices if there is none)."""
    if name not in CLOCKS:
        raise PegbtError(f"unknown clock {name!r}; known: {', '.join(CLOCKS)}", field="--clock")
    return _load(CLOCKS[name])()


def run_options(given: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Every registered option: the given values, defaults for the rest; a `PegbtError` for an unknown or invalid one."""
    given = dict(given or {})
    unknown = sorted(set(given) - set(RUN_OPTIONS))
    if unknown:
        raise PegbtError(
            f"unknown run option {unknown[0]!r}; known: {', '.join(RUN_OPTIONS)}", field=unknown[0]
        )
    options = {}
    for name, option in RUN_OPTIONS.items():
        value = given.get(name, option.default)
        if value is not None and option.choices and value not in option.choices:
            raise PegbtError(
                f"{value!r} is not one of {', '.join(map(str, option.choices))}", field=f"--{name}"
            )
        options[name] = value
    return options


def provide_resources(users: Mapping[str, str], setup: ProviderSetup) -> dict[str, Any]:
    """One instance of each resource in `users` (name -> who needs it); a `PegbtError` for any without a provider.

    If a provider fails, the resources already provided are closed before the error propagates.
    """
    missing = [
        f"{name!r} (needed by {user})"
        for name, user in sorted(users.items())
        if name not in RESOURCE_PROVIDERS
    ]
    if missing:
        raise PegbtError(
            f"no provider for resource {'; '.join(missing)}; providers are registered in "
            "pegbt/executive/providers.py",
            field="resources",
        )
    resources: dict[str, Any] = {}
    try:
        for name in sorted(users):
            resources[name] = _load(RESOURCE_PROVIDERS[name])(setup)
    except BaseException:
        close_resources(resources)
        raise
    return resources


def resource_clock(resources: Mapping[str, Any], requested: str | None) -> tuple[Clock | None, str]:
    """The clock a resource supplies (and its name), if one does; a `PegbtError` if `--clock` asked for another."""
    supplied = [
        (name, resource.run_clock)
        for name, resource in sorted(resources.items())
        if isinstance(getattr(resource, "run_clock", None), Clock)
    ]
    if len(supplied) > 1:
        raise PegbtError(
            f"resources {', '.join(name for name, _ in supplied)} each supply a clock", field="resources"
        )
    if not supplied:
        return None, requested or "wall"
    name, clock = supplied[0]
    if requested is not None:
        raise PegbtError(
            f"resource {name!r} supplies the run's clock ({type(clock).__name__}); drop --clock {requested}",
            field="--clock",
        )
    return clock, f"{name} ({type(clock).__name__})"


def close_resources(resources: Mapping[str, Any]) -> None:
    """Call `close()` on each resource that has one (in reverse order of provision)."""
    for resource in reversed(list(resources.values())):
        close = getattr(resource, "close", None)
        if callable(close):
            close()
