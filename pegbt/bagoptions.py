"""Command-line options for ROS 2 bags: those that choose a bag's topics and samples (`pegbt sim2real
diagnose`, `pegbt calibrate train|eval`) and those that record one (`pegbt run`, `pegbt calibrate collect`,
`pegbt sim`), kept apart from the reader and the recorder so that building the parser imports neither."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TypedDict

from pegbt.numbers import NumberOption

DEFAULT_CMD = "/{arm}/setpoint_js"
DEFAULT_PHY = "/{arm}/fiducial_js"


def add_bag_arguments(parser: argparse.ArgumentParser) -> None:
    """`--cmd`, `--phy` and `--settled`, for commands that read a recording that may be a bag."""
    parser.add_argument(
        "--cmd", metavar="TOPIC", help=f"a bag's command topic (default {DEFAULT_CMD.format(arm='PSMn')})"
    )
    parser.add_argument(
        "--phy",
        metavar="TOPIC",
        help=f"a bag's physical-joint topic (default {DEFAULT_PHY.format(arm='PSMn')}; a dVRK's tracker topic)",
    )
    parser.add_argument(
        "--settled",
        action=NumberOption,
        at_least=0.0,
        metavar="S",
        help="keep a bag's samples only where the command had not changed for S seconds",
    )


class BagOptions(TypedDict):
    """`load_recording`'s keywords for a bag."""

    cmd: str | None
    phy: str | None
    settled: float | None


class RecordOptions(TypedDict):
    """`RunOptions`' keywords for a recording."""

    record: Path | None
    record_cloud_step: int


def bag_options(args: argparse.Namespace) -> BagOptions:
    """The bag arguments of `add_bag_arguments` as `load_recording` keywords."""
    return {"cmd": args.cmd, "phy": args.phy, "settled": args.settled}


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """`--record FILE.mcap` and `--record-cloud-step K`, for commands whose traffic can be recorded."""
    parser.add_argument(
        "--record",
        metavar="FILE.mcap",
        help="record the CRTK topics, camera clouds, tick statuses and simulator events to an MCAP file",
    )
    parser.add_argument(
        "--record-cloud-step",
        action=NumberOption,
        type=int,
        at_least=1,
        default=10,
        metavar="K",
        help="keep every K-th point of each camera cloud in the recording (1: whole clouds; default 10)",
    )


def record_options(args: argparse.Namespace) -> RecordOptions:
    """The arguments of `add_record_arguments` as `RunOptions` keywords."""
    return {
        "record": None if args.record is None else Path(args.record),
        "record_cloud_step": args.record_cloud_step,
    }
