"""The monitor's port option, shared by `pegbt monitor --port` and `pegbt run --monitor`; light, so the parser
loads neither the server nor aiohttp."""

from __future__ import annotations

import argparse

from pegbt.numbers import NumberOption


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
