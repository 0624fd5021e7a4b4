"""Command-line options of the simulated world and robot that `pegbt sim` serves with and `pegbt eval`
passes to each trial's simulator (`--world-effects`, `--camera`, `--robot-clock-offset`), and the check
that the dVRK interface's come with it: one definition, so that the two commands cannot drift apart."""

from __future__ import annotations

import argparse
from pathlib import Path

from pegbt.errors import PegbtError
from pegbt.numbers import NumberOption

CAMERAS = ("stream", "zivid")


def add_sim_world_arguments(parser: argparse.ArgumentParser, for_trials: bool = False) -> None:
    """`--world-effects`, `--camera` and `--robot-clock-offset`; `for_trials`: the command starts a
    simulator per trial (`pegbt eval`) and gives it these, and the camera choice to the run as well."""
    relay = " Each trial's `pegbt sim` gets it" if for_trials else ""
    parser.add_argument(
        "--world-effects",
        type=Path,
        metavar="YAML",
        help="world file: the contact physics the world adds (bending pegs, chamfers, a compliant or "
        "slipping grip, a registration offset, a depth bias; `pegbt sim2real outcomes --effects` lists them)."
        + relay,
    )
    parser.add_argument(
        "--camera",
        choices=CAMERAS,
        default="stream",
        help="--interface dvrk: stream: a depth camera streaming PointCloud2, as realsense2_camera does (the "
        "default); zivid: a Zivid 2 as `ros2 run zivid_camera zivid_camera` serves it: the service /capture "
        "(std_srvs/srv/Trigger) captures one organised, full-resolution cloud (1944 x 1200 points, NaN where "
        "a pixel sees nothing, frame zivid_optical_frame) and publishes it on /points/xyzrgba and /points/xyz, "
        "each only if somebody subscribes, before it responds."
        + (" Each trial's `pegbt sim` and `pegbt run` get it" if for_trials else ""),
    )
    parser.add_argument(
        "--robot-clock-offset",
        action=NumberOption,
        default=0.0,
        metavar="SECONDS",
        help="--interface dvrk: stamp everything the robot sends on a clock this far ahead of this computer's "
        "(negative: behind), as a robot computer whose clock is not synchronised (default 0)." + relay,
    )


def refuse_dvrk_only(args: argparse.Namespace) -> None:
    """A `PegbtError` naming `--robot-clock-offset` or `--camera` given without `--interface dvrk`."""
    if args.interface == "dvrk":
        return
    if args.robot_clock_offset:
        raise PegbtError(
            "--robot-clock-offset is the dVRK interface's (pegbt's stamps on the simulator's clock): add "
            "--interface dvrk",
            field="--robot-clock-offset",
        )
    if args.camera != "stream":
        raise PegbtError(
            f"--camera {args.camera} is a ROS 2 camera driver's: add --interface dvrk", field="--camera"
        )
