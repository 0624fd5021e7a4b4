"""The `pegbt` command: a thin parser that hands each subcommand to the subpackage that owns it.

Each module in `COMMAND_MODULES` exposes `add_commands(subparsers)`, which registers its subcommands
and sets `handler` on them. Handlers import heavy libraries lazily so `pegbt --help` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from pegbt import __version__
from pegbt.errors import PegbtError

COMMAND_MODULES: tuple[str, ...] = (
    "pegbt.bench.cli",
    "pegbt.executive.cli",
    "pegbt.calibration.cli",
    "pegbt.sim.cli",
    "pegbt.sim2real.cli",
    "pegbt.evaluation.cli",
)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser, with every subpackage's subcommands registered."""
    parser = argparse.ArgumentParser(
        prog="pegbt",
        description="Behaviour-tree executive for dVRK peg transfer, its simulator and sim-to-real tools.",
    )
    parser.add_argument("--version", action="version", version=f"pegbt {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module_name in COMMAND_MODULES:
        importlib.import_module(module_name).add_commands(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one `pegbt` command; returns the process exit status."""
    args = build_parser().parse_args(argv)
    try:
        status = args.handler(args)
    except PegbtError as error:
        print(f"pegbt: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pegbt: interrupted", file=sys.stderr)
        return 130
    return int(status or 0)
