"""`pegbt sim2real outcomes REAL|--table paper`: read the outcomes, diagnose, write and print the report."""

from __future__ import annotations

import argparse
import json
import logging
import shlex
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from pegbt.errors import PegbtError
from pegbt.sim2real.outcomes.cells import Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose, split
from pegbt.sim2real.outcomes.report import report_dict, report_markdown, write_report
from pegbt.sim2real.outcomes.simulate import attempts_for, registered_for
from pegbt.sim2real.outcomes.table import paper_table, read_table
from pegbt.sim2real.outcomes.workers import ClusterMapper, LocalMapper

if TYPE_CHECKING:
    from pegbt.evaluation.cluster import ClusterTls


def read_outcomes(real: str | None, table: str | None) -> Outcomes:
    """The real outcomes: the built-in table, a folder of tick logs, or a table file."""
    if table == "paper":
        return paper_table()
    assert real is not None  # the command line asks for one of them
    path = Path(real)
    if path.is_dir():
        from pegbt.sim2real.outcomes.ticklogs import read_tick_logs

        return read_tick_logs(path)
    if not path.exists():
        raise PegbtError("no such file or folder", file=real)
    return read_table(path)


def run_outcomes(args: argparse.Namespace, tls: ClusterTls | None = None) -> int:
    """`pegbt sim2real outcomes REAL`: the diagnosis, its report and its JSON; `tls`: the certificates of a
    `--cluster tls://` scheduler, already checked."""
    if args.confirm and not args.out:
        raise PegbtError("--confirm writes its campaigns beside the report: give --out", field="--confirm")
    outcomes = read_outcomes(args.real, args.table)
    settings = Settings(fit=args.fit, transfers=args.transfers, located=args.located, points=args.points)
    split(outcomes.cells, settings.fit)  # a bad --fit is said before any simulation
    logging.getLogger("pegbt").setLevel(logging.ERROR)  # compensation clamps, once per simulated transfer
    attempts, registered = attempts_for(outcomes), registered_for(outcomes)
    mapper = (
        ClusterMapper(args.cluster, attempts, registered, tls)
        if args.cluster
        else LocalMapper(args.workers, attempts, registered)
    )
    try:
        diagnosis = diagnose(
            outcomes, settings, mapper, progress=lambda line: print(line, file=sys.stderr, flush=True)
        )
    finally:
        mapper.close()
    commands = ["pegbt " + shlex.join(sys.argv[1:])] if sys.argv[1:2] == ["sim2real"] else []
    if args.out:
        data = write_report(diagnosis, Path(args.out), commands)
        if args.confirm and data["world_files"]:
            from pegbt.sim2real.outcomes.confirm import confirm

            confirmed = {
                world: confirm(
                    Path(world),
                    outcomes.cells,
                    args.confirm,
                    Path(args.out) / "confirm",
                    args.workers,
                    until_lost=outcomes.attempts_end_at_lost_block,
                    protocol="paper" if registered else "pegbt",
                )
                for world in data["world_files"]
            }
            data = write_report(diagnosis, Path(args.out), commands, confirmed)
        print(
            f"wrote {args.out}/report.md, report.json, outcomes.png"
            + "".join(f", {w}" for w in data["world_files"] + data["open_world_files"]),
            file=sys.stderr,
        )
    if args.json:
        print(json.dumps(report_dict(diagnosis, commands), indent=2))
    else:
        print(report_markdown(diagnosis, commands))
    return 0
