"""The command-line options that choose a bag's topics and samples (`pegbt sim2real diagnose`, `pegbt
calibrate train|eval`), kept apart from the bag reader so that building the parser imports no numerics."""

from __future__ import annotations

import argparse

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


def bag_options(args: argparse.Namespace) -> dict[str, object]:
    """The bag arguments of `add_bag_arguments` as `load_recording` keywords."""
    return {"cmd": args.cmd, "phy": args.phy, "settled": args.settled}
