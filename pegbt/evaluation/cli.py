"""`pegbt eval`: N seeded trials of one task variant and condition on the embedded simulator, judged by
its ground truth, printed as the paper's table (or one JSON object) and written as CSV and box plots."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.errors import PegbtError
from pegbt.numbers import NumberOption
from pegbt.runconditions import CONDITIONS, PROTOCOLS, VARIANTS, known_condition, known_protocol
from pegbt.simoptions import add_sim_world_arguments, refuse_dvrk_only

if TYPE_CHECKING:
    from pegbt.evaluation.cluster import ClusterTls
    from pegbt.evaluation.trial import TrialRecord

INTERFACES = ("pegbt", "dvrk")  # as `pegbt.evaluation.trial.INTERFACES` (not imported: it pulls in the robot)


def add_commands(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "eval",
        help="run N seeded peg-transfer trials on the simulator and report the paper's table",
        description="Run trials of one task variant and condition on the embedded simulator (lockstep, dvrk-real "
        "physics, depth noise), seeds S..S+N-1, each judged by the simulator's ground truth; print the paper's "
        "table beside its figures; write per-trial and per-transfer CSV, a JSON summary and box plots to DIR.",
    )
    parser.add_argument(
        "--variant", required=True, metavar="NAME", help=f"task variant: {', '.join(VARIANTS)}"
    )
    parser.add_argument(
        "--trials", type=int, required=True, metavar="N", help="number of trials (seeds S..S+N-1)"
    )
    parser.add_argument(
        "--condition", default="optimized", metavar="C", help=f"{', '.join(CONDITIONS)} (default optimized)"
    )
    parser.add_argument("--seed", type=int, default=0, metavar="S", help="first seed (default 0)")
    parser.add_argument(
        "--protocol",
        default="pegbt",
        metavar="P",
        help=f"{' or '.join(PROTOCOLS)}: the trees' own (recovery, pegbt's heights; the default) or the reference "
        "paper's (one attempt per block, the arms registered to the camera as its were, with cubic motions a "
        "look at the held block before lowering it and at the block held out before taking it), as "
        "`pegbt run --protocol`",
    )
    faults = parser.add_mutually_exclusive_group()
    faults.add_argument(
        "--faults",
        type=Path,
        metavar="PLAN",
        help="fault plan (YAML, as `pegbt sim --faults`) for every trial",
    )
    faults.add_argument(
        "--inject-faults",
        action="store_true",
        help="a fault plan per seed: a missed grasp, slips, depth-noise bursts (written to DIR/faults/)",
    )
    add_sim_world_arguments(parser, for_trials=True)
    parser.add_argument(
        "--realtime",
        action="store_true",
        help="each trial's simulator runs in real time and the run on the wall clock (default: lockstep)",
    )
    parser.add_argument(
        "--interface",
        choices=INTERFACES,
        default="pegbt",
        help="what the simulator serves and the run speaks: pegbt (its own topics and extensions, the "
        "default) or dvrk (what a dVRK serves through zenoh-bridge-ros2dds); passed to `pegbt sim "
        "--interface` and `pegbt run --interface`",
    )
    parser.add_argument(
        "--speed",
        action=NumberOption,
        above=0.0,
        at_most=1.0,
        default=1.0,
        metavar="F",
        help="every run moves at this fraction of the planner's speed, as `pegbt run --speed` (default 1)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("runs/eval"),
        metavar="DIR",
        help="results directory (default runs/eval)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=2,
        metavar="K",
        help="trials run at once, each with its own simulator (default 2)",
    )
    parser.add_argument(
        "--cluster",
        metavar="ADDRESS",
        help="run each trial as a task on this Dask scheduler (tls://HOST:PORT with the --tls options, or "
        "tcp://HOST:PORT on a trusted network; needs the cluster extra) instead of --workers local "
        "processes; logs come back here unless the workers see --out",
    )
    add_tls_options(parser)
    parser.add_argument(
        "--keep-logs",
        action="store_true",
        help="keep every trial's tick log (default: only trials with a failure or a fault)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    parser.add_argument("--quiet", action="store_true", help="no line per finished trial on stderr")
    parser.set_defaults(handler=_eval)


def check_arguments(args: argparse.Namespace) -> None:
    """Bad input as one `PegbtError` (the CLI prints one line and exits 2)."""
    if args.variant not in VARIANTS:
        raise PegbtError(f"unknown variant {args.variant!r}; known: {', '.join(VARIANTS)}", field="--variant")
    known_condition(args.condition)
    known_protocol(args.protocol)
    for name in ("trials", "workers"):
        if getattr(args, name) <= 0:
            raise PegbtError(f"must be at least 1, got {getattr(args, name)}", field=f"--{name}")
    if args.seed < 0:
        raise PegbtError(f"seeds are non-negative, got {args.seed}", field="--seed")
    checked_cluster_tls(args)
    if args.faults is not None:
        from pegbt.sim.fault_plan import FaultPlan

        FaultPlan.load(args.faults)  # unreadable or invalid: its error names the file, line and field
    if args.world_effects is not None:
        from pegbt.sim.world_effects import read_world_file

        read_world_file(args.world_effects)  # refused here, with its location, not in every trial
    check_interface(args.interface, args.realtime)
    refuse_dvrk_only(args)


def add_tls_options(parser: argparse.ArgumentParser) -> None:
    """`--tls-ca-file`, `--tls-cert` and `--tls-key`: the certificates of a `--cluster tls://` scheduler."""
    parser.add_argument(
        "--tls-ca-file", type=Path, metavar="PEM", help="--cluster tls://: the CA certificate"
    )
    parser.add_argument(
        "--tls-cert", type=Path, metavar="PEM", help="--cluster tls://: this client's certificate"
    )
    parser.add_argument(
        "--tls-key", type=Path, metavar="PEM", help="--cluster tls://: this client's private key"
    )


def checked_cluster_tls(args: argparse.Namespace) -> ClusterTls | None:
    """`--cluster`'s address and certificates checked before any connection (`add_tls_options`): the
    certificates, or None; a `PegbtError` for certificates without `--cluster` or a bad address."""
    if any((args.tls_ca_file, args.tls_cert, args.tls_key)) and args.cluster is None:
        raise PegbtError("the --tls options are for --cluster tls://HOST:PORT", field="--tls-ca-file")
    tls = cluster_tls(args)
    if args.cluster is not None:
        from pegbt.evaluation.cluster import check_address

        check_address(args.cluster, tls)
    return tls


def cluster_tls(args: argparse.Namespace) -> ClusterTls | None:
    """The three --tls files, None if none is given, or a `PegbtError` naming the one missing."""
    from pegbt.evaluation.cluster import TLS_OPTIONS, ClusterTls

    files = (args.tls_ca_file, args.tls_cert, args.tls_key)
    if not any(files):
        return None
    for option, path in zip(TLS_OPTIONS, files, strict=True):
        if path is None:
            raise PegbtError(f"give all of {', '.join(TLS_OPTIONS)}, or none", field=option)
    return ClusterTls(*files)


def check_interface(interface: str, realtime: bool) -> None:
    """A `PegbtError` for the dVRK interface without `--realtime`: a robot's interface has no lockstep."""
    if interface != "pegbt" and not realtime:
        raise PegbtError(
            f"--interface {interface} runs in real time, as a robot does: add --realtime", field="--interface"
        )


def _eval(args: argparse.Namespace) -> int:
    check_arguments(args)
    from pegbt.evaluation.campaign import Cell, run_trials, trial_specs
    from pegbt.evaluation.figures import plot_trial_figures
    from pegbt.evaluation.output import plot_transfer_times, write_cell
    from pegbt.evaluation.summary import summarise, table

    cell = Cell(
        args.variant,
        args.condition,
        args.trials,
        args.seed,
        None if args.faults is None else args.faults.resolve(),
        args.inject_faults,
        realtime=args.realtime,
        interface=args.interface,
        world_effects=None if args.world_effects is None else args.world_effects.resolve(),
        camera=args.camera,
        speed=args.speed,
        robot_clock_offset=args.robot_clock_offset,
        protocol=args.protocol,
    )
    specs = trial_specs(cell, args.out, keep_logs=args.keep_logs)
    done = None if args.quiet else _report_trial
    if args.cluster is None:
        records, workers = run_trials(specs, args.workers, done=done), args.workers
    else:
        from pegbt.evaluation.cluster import run_trials_on_cluster

        records, workers = run_trials_on_cluster(specs, args.cluster, done=done, tls=cluster_tls(args))
    figures = summarise(cell, records, min(workers, args.trials))
    paths = write_cell(args.out, cell, records, figures)
    if not (args.faults or args.inject_faults):
        paths += [plot_transfer_times(args.out), plot_trial_figures(args.out)]
    if args.json:
        print(json.dumps(figures))
    else:
        print(table(figures))
        print("wrote " + ", ".join(str(path) for path in paths))
    return 0


def _report_trial(record: TrialRecord) -> None:
    if record.outcome == "error":
        line = f"error: {record.error}"
    else:
        mean = "-" if record.mean_transfer_time_s is None else f"{record.mean_transfer_time_s:.2f} s"
        line = (
            f"{record.transfers_succeeded}/{record.transfers_attempted} transfers, mean {mean}, "
            f"trial {record.trial_time_s:.1f} s, wall {record.wall_time_s:.1f} s"
        )
    if record.commands_clipped or record.arm_faults:
        line += f"; {record.commands_clipped} command(s) clipped, {record.arm_faults} FAULT(s)"
    print(f"seed {record.seed}: {line}", file=sys.stderr, flush=True)
