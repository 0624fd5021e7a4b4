"""`pegbt monitor LOG --port PORT`: replay a tick log in the browser (`pegbt run --monitor PORT` shows a live run)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from pegbt.numbers import NumberOption

if TYPE_CHECKING:
    from pegbt.monitor.history import History
    from pegbt.monitor.server import MonitorServer


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    monitor = subparsers.add_parser(
        "monitor", help="replay a tick log in the browser: tree, timeline, blackboard, first cause, 3D world"
    )
    monitor.add_argument("log", metavar="LOG")
    add_port_option(monitor, "--port", default=8765)
    add_no_token_option(monitor)
    monitor.set_defaults(handler=_monitor)


def add_port_option(parser: argparse.ArgumentParser, name: str, default: int | None) -> None:
    parser.add_argument(
        name,
        action=NumberOption,
        type=int,
        at_least=1,
        at_most=65535,
        default=default,
        metavar="PORT",
        help=f"serve the monitor page on http://127.0.0.1:PORT/{f' (default {default})' if default else ''}",
    )


def add_no_token_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--no-token",
        action="store_true",
        help="serve the run without the URL's token: any program on this machine can then read it",
    )


def start_server(port: int, no_token: bool, history: History | None = None) -> MonitorServer:
    """The started server, with a warning on stderr when it needs no token."""
    from pegbt.monitor.server import MonitorServer

    server = MonitorServer(port, require_token=not no_token, history=history).start()
    if no_token:
        print(
            f"monitor: --no-token: any program on this machine that connects to port {server.port} can read "
            "the run (web pages still cannot: Origin and Host are checked)",
            file=sys.stderr,
            flush=True,
        )
    return server


def _monitor(args: argparse.Namespace) -> int:
    from pegbt.executive.cli import read_log
    from pegbt.monitor.history import History
    from pegbt.monitor.replay import replay_messages

    messages = replay_messages(read_log(args.log, keep_records=True))
    server = start_server(int(args.port), args.no_token, History.whole())
    for message in messages:
        server.publish(message)
    try:
        server.serve_until_interrupted(f"replay of {args.log}")
    finally:
        server.stop()
    return 0
