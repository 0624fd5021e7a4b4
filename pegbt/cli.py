"""The `pegbt` command: a thin parser that hands each subcommand to the subpackage that owns it.

Each module in `COMMAND_MODULES` exposes `add_commands(subparsers)`, which registers its subcommands
and sets `handler` on them. Handlers import heavy libraries lazily so `pegbt --help` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import os
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
    "pegbt.monitor.cli",
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


BROKEN_PIPE_STATUS = 141  # what a shell reports for a process killed by SIGPIPE


def main(argv: list[str] | None = None) -> int:
    """Run one `pegbt` command; returns the process exit status.

    Bad input (a `PegbtError`, also from an option's value) is one line on stderr and status 2. A reader
    that stops early (`pegbt tree schema | head`) ends the command quietly, as it would a Unix tool.
    """
    try:
        args = build_parser().parse_args(argv)
        status = args.handler(args)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's own flush at exit
    except PegbtError as error:
        print(f"pegbt: error: {error}", file=sys.stderr)
        return error.exit_status
    except KeyboardInterrupt as stop:
        print(f"pegbt: interrupted by {stop.args[0] if stop.args else 'SIGINT'}", file=sys.stderr)
        return getattr(stop, "status", 130)
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # nothing left to flush at exit
        return BROKEN_PIPE_STATUS
    return int(status or 0)
