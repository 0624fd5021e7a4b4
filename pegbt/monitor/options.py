"""What `pegbt monitor` and `pegbt run --monitor` share: the port and token options and starting the server.
Light, so building the parser loads neither the server nor aiohttp."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from pegbt.numbers import NumberOption

if TYPE_CHECKING:
    from pegbt.monitor.history import History
    from pegbt.monitor.server import MonitorServer


def add_port_option(parser: argparse.ArgumentParser, name: str, default: int | None) -> None:
    """`name PORT`: a TCP port (1-65535) on 127.0.0.1 for the monitor page."""
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
