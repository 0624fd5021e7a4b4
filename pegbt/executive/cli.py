"""`pegbt tree check|show|schema`, `pegbt run` and `pegbt log summary|why|replay|export`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.bagoptions import add_record_arguments, record_options
from pegbt.errors import PegbtError
from pegbt.executive.providers import RUN_OPTIONS
from pegbt.monitor.options import add_no_token_option, add_port_option
from pegbt.numbers import NumberOption
from pegbt.stopsignals import stop_signals

INTERRUPTED = 130  # 128 + SIGINT: a Ctrl-C that reached the runner as KeyboardInterrupt

if TYPE_CHECKING:
    from pegbt.monitor.live import LiveMonitor


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    tree = subparsers.add_parser("tree", help="check, show and describe YAML behaviour trees")
    tree_commands = tree.add_subparsers(dest="tree_command", metavar="COMMAND", required=True)
    check = tree_commands.add_parser(
        "check", help="validate tree files without running them; all errors, each FILE:LINE:COLUMN"
    )
    check.add_argument("files", nargs="+", metavar="FILE")
    _include_option(check)
    check.set_defaults(handler=_tree_check)
    show = tree_commands.add_parser("show", help="print a tree (ASCII), or write Graphviz with --dot")
    show.add_argument("file", metavar="FILE")
    show.add_argument("--dot", metavar="OUT", help="write the tree as a Graphviz .dot file")
    _include_option(show)
    show.set_defaults(handler=_tree_show)
    schema = tree_commands.add_parser("schema", help="list every node type and behaviour with its parameters")
    schema.set_defaults(handler=_tree_schema)

    run = subparsers.add_parser(
        "run", help="run a behaviour tree until it succeeds, fails or times out; writes a tick log"
    )
    run.add_argument("tree", metavar="TREE")
    run.add_argument(
        "--period",
        action=NumberOption,
        above=0.0,
        default=0.02,
        metavar="S",
        help="tick period, s (default 0.02)",
    )
    run.add_argument(
        "--timeout",
        action=NumberOption,
        above=0.0,
        default=None,
        metavar="S",
        help="halt the tree after S seconds",
    )
    run.add_argument("--log", metavar="FILE", help="tick log path (default runs/TREE-DATE-TIME.jsonl)")
    run.add_argument(
        "--clock",
        default=None,
        metavar="NAME",
        help="wall (default): real time; manual: time that advances one period per tick, without sleeping; "
        "others as registered in pegbt/executive/providers.py; a resource that is a time source "
        "(a simulator in lockstep) supplies its own",
    )
    run.add_argument("--quiet", action="store_true", help="no progress bar, no progress lines")
    run.add_argument(
        "--verbose", action="store_true", help="a line for every leaf that finishes, not only failures"
    )
    add_port_option(run, "--monitor", default=None)
    add_no_token_option(run)
    add_record_arguments(run)
    _include_option(run)
    for option in RUN_OPTIONS.values():
        run.add_argument(
            f"--{option.name}",
            dest=f"option_{option.name}",
            type=option.type,
            default=option.default,
            choices=option.choices or None,
            help=f"{option.help} (default {option.default})",
        )
    run.set_defaults(handler=_run)

    log = subparsers.add_parser("log", help="analyse tick logs written by `pegbt run`")
    log_commands = log.add_subparsers(dest="log_command", metavar="COMMAND", required=True)
    summary = log_commands.add_parser(
        "summary", help="outcome, duration, ticks, per-node counts, slowest leaves"
    )
    summary.add_argument("log", metavar="LOG")
    summary.set_defaults(handler=_log_summary)
    why = log_commands.add_parser(
        "why", help="causal chain from the root's failure to the leaf failures; recoveries"
    )
    why.add_argument("log", metavar="LOG")
    why.set_defaults(handler=_log_why)
    replay = log_commands.add_parser("replay", help="every node's status at one tick or time")
    replay.add_argument("log", metavar="LOG")
    moment = replay.add_mutually_exclusive_group(required=True)
    moment.add_argument("--tick", type=int, metavar="N")
    moment.add_argument(
        "--time",
        action=NumberOption,
        at_least=0.0,
        metavar="T",
        help="seconds since the start (executive clock)",
    )
    replay.set_defaults(handler=_log_replay)
    plot = log_commands.add_parser(
        "plot", help="draw the run's timeline: each arm's activity, transfers, failures, recoveries"
    )
    plot.add_argument("log", metavar="LOG")
    plot.add_argument("--out", metavar="FILE", help="the figure to write (PNG, SVG, PDF; default LOG.png)")
    plot.set_defaults(handler=_log_plot)
    export = log_commands.add_parser(
        "export", help="convert a tick log to Groot2's .btlog (BehaviorTree.CPP FileLogger2)"
    )
    export.add_argument("log", metavar="LOG")
    export.add_argument("out", metavar="OUT", help="the .btlog file to write")
    export.set_defaults(handler=_log_export)


def _include_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--allow-include-outside",
        action="store_true",
        help="let `include:` name files outside the tree file's folder (refused by default)",
    )


def _tree_check(args: argparse.Namespace) -> int:
    from pegbt.executive.loader import check_tree

    failed = 0
    for file in args.files:
        errors = check_tree(file, allow_include_outside=args.allow_include_outside)
        for error in errors:
            print(error, file=sys.stderr)
        if errors:
            failed += 1
            print(f"{file}: {len(errors)} error(s)", file=sys.stderr)
        else:
            print(f"{file}: ok")
    return 2 if failed else 0


def _tree_show(args: argparse.Namespace) -> int:
    import py_trees

    from pegbt.executive.loader import load_tree

    built = load_tree(args.file, allow_include_outside=args.allow_include_outside).build()
    if args.dot:
        try:
            Path(args.dot).write_text(py_trees.display.dot_tree(built.root).to_string(), encoding="utf-8")
        except OSError as error:
            raise PegbtError(
                f"cannot write the dot file: {error.strerror}", file=args.dot, field="--dot"
            ) from None
        print(f"wrote {args.dot}")
    else:
        print(py_trees.display.ascii_tree(built.root), end="")
    return 0


def _tree_schema(args: argparse.Namespace) -> int:
    from pegbt.executive.schema import schema_text

    print(schema_text())
    return 0


def _run(args: argparse.Namespace) -> int:
    from pegbt.behaviours.resources.robot import simulated_world
    from pegbt.executive.analysis import result_table
    from pegbt.executive.logfile import read_tick_log
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import default_log_path, run_tree_file

    options = {name: getattr(args, f"option_{name}") for name in RUN_OPTIONS}
    log_path = Path(args.log) if args.log else default_log_path(args.tree)
    run_options = RunOptions(
        Path(args.tree),
        log_path,
        options,
        clock=args.clock,
        period=args.period,
        timeout=args.timeout,
        allow_include_outside=args.allow_include_outside,
        world=simulated_world(options, args.clock),
        **record_options(args),
    )
    monitor = _start_monitor(args.monitor, args.no_token, log_path) if args.monitor is not None else None
    try:
        with stop_signals() as received:
            output = run_tree_file(
                run_options,
                quiet=args.quiet,
                verbose=args.verbose,
                watch=monitor.watch if monitor else None,
            )
    except BaseException:
        if monitor:
            monitor.stop()
        raise
    reports = list(output.reports.values())
    if reports:  # a resource that judges the run says more than the per-node table
        print(
            f"outcome: {output.result.outcome} in {output.result.duration:.3f} s, {output.result.ticks} ticks"
        )
        for report in reports:
            print(report)
    else:
        print(result_table(read_tick_log(log_path)))
    print(f"tick log: {log_path}" + (f"; recording: {args.record}" if args.record else ""))
    if output.result.outcome == "interrupted":
        if monitor:
            monitor.stop()
        print(f"pegbt: interrupted by {received.name or 'SIGINT'}: the tree was halted", file=sys.stderr)
        return received.status if received.signum else INTERRUPTED
    if monitor:
        monitor.serve_until_interrupted()
    return 0 if output.ok else 1


def _start_monitor(port: int, no_token: bool, log_path: Path) -> LiveMonitor:
    from pegbt.monitor.live import LiveMonitor
    from pegbt.monitor.options import start_server

    server = start_server(int(port), no_token)
    print(f"monitor: {server.url}", flush=True)
    return LiveMonitor(server, log_path)


def _log_summary(args: argparse.Namespace) -> int:
    from pegbt.executive.analysis import summary
    from pegbt.executive.logfile import read_log_warning

    print(summary(read_log_warning(args.log)))
    return 0


def _log_why(args: argparse.Namespace) -> int:
    from pegbt.executive.analysis import why
    from pegbt.executive.logfile import read_log_warning

    print(why(read_log_warning(args.log)))
    return 0


def _log_replay(args: argparse.Namespace) -> int:
    from pegbt.executive.analysis import replay
    from pegbt.executive.logfile import read_log_warning

    print(replay(read_log_warning(args.log), tick=args.tick, time=args.time))
    return 0


def _log_plot(args: argparse.Namespace) -> int:
    from pegbt.executive.logfile import read_log_warning
    from pegbt.executive.logplot import figure_format, plot_timeline
    from pegbt.monitor.world import read_world_log, world_log_path

    out = Path(args.out) if args.out else Path(args.log).with_suffix(".png")
    figure_format(out)
    world = world_log_path(args.log)
    faults = [
        fault
        for sample in (read_world_log(world) if world.exists() else [])
        for fault in sample.get("faults", [])
    ]
    try:
        plot_timeline(read_log_warning(args.log), out, faults)
    except OSError as error:
        raise PegbtError(f"cannot write the figure: {error.strerror}", file=out, field="--out") from None
    print(f"wrote {out}")
    return 0


def _log_export(args: argparse.Namespace) -> int:
    from pegbt.executive.btlog import export_btlog
    from pegbt.executive.logfile import read_log_warning

    count = export_btlog(read_log_warning(args.log), Path(args.out))
    print(f"wrote {args.out} ({count} transitions)")
    return 0
