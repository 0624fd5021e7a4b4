"""`pegbt monitor LOG --port PORT`: replay a tick log in the browser (`pegbt run --monitor PORT` shows a live run)."""

from __future__ import annotations

import argparse

from pegbt.monitor.options import add_no_token_option, add_port_option, start_server


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    monitor = subparsers.add_parser(
        "monitor", help="replay a tick log in the browser: tree, timeline, blackboard, first cause, 3D world"
    )
    monitor.add_argument("log", metavar="LOG")
    add_port_option(monitor, "--port", default=8765)
    add_no_token_option(monitor)
    monitor.set_defaults(handler=_monitor)


def _monitor(args: argparse.Namespace) -> int:
    from pegbt.executive.logfile import read_log_warning
    from pegbt.monitor.history import History
    from pegbt.monitor.replay import replay_messages

    messages = replay_messages(read_log_warning(args.log, keep_records=True))
    server = start_server(int(args.port), args.no_token, History.whole())
    for message in messages:
        server.publish(message)
    try:
        server.serve_until_interrupted(f"replay of {args.log}")
    finally:
        server.stop()
    return 0
