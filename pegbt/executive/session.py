"""One run of a tree file, from loading to the resources' reports: what `pegbt run` does, callable from code.

`run_tree_file` runs one `RunOptions`: it loads and checks the tree, provides its resources (with the
run's options), takes the clock a resource supplies (else the one asked for), builds, runs with a tick
log whose header records the options, collects each resource's `report()` while the resources are still
open, and closes them whatever happens.
"""

from __future__ import annotations

import datetime
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from pegbt.errors import PegbtError
from pegbt.executive.build import BuiltTree
from pegbt.executive.context import RunContext
from pegbt.executive.loader import load_tree
from pegbt.executive.progress import ProgressPrinter, tick_bar
from pegbt.executive.providers import (
    LogsMessages,
    ProviderSetup,
    Reports,
    ShowsProgress,
    close_resources,
    make_clock,
    provide_resources,
    resource_clock,
)
from pegbt.executive.runner import RunResult, run
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.ticklog import Record, TickLogWriter


def default_log_path(tree: str | Path) -> Path:
    """Where a run's tick log goes unless told: `runs/TREE-DATE-TIME.jsonl` under the working directory."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{Path(tree).stem}-{stamp}.jsonl"


@dataclass
class RunOutput:
    """How the run ended, each resource's report (by resource name) and where the tick log is."""

    result: RunResult
    log_path: Path
    reports: dict[str, Any] = field(default_factory=dict)  # only resources that had something to report

    @property
    def ok(self) -> bool:
        """The tree succeeded and no report says otherwise."""
        return self.result.outcome == "success" and all(
            getattr(report, "ok", True) for report in self.reports.values()
        )


def run_tree_file(
    options: RunOptions,
    *,
    quiet: bool = True,
    out: IO[str] | None = None,
    verbose: bool = False,
    watch: Callable[[BuiltTree, Mapping[str, Any]], list[Callable[[dict[str, Any]], None]]] | None = None,
) -> RunOutput:
    """Run the tree file of `options` once; see the module docstring. `quiet=False` prints progress to
    `out` (default: `sys.stdout` as it is when called); `verbose` prints every leaf's result, not only
    failures and recoveries; `watch(built, resources)` returns more tick-log listeners (`pegbt run
    --monitor`). A recording (`options.record`) holds what the resources' links carry and the tick
    log's status changes (`pegbt.transport.recorder`)."""
    out = out or sys.stdout
    tree, log_path, clock = options.tree, options.log, options.clock
    loaded = load_tree(tree, allow_include_outside=options.allow_include_outside)
    # each key set by what asked for it, so that one the tree lacks is refused in the asker's words
    asked = {key: options.asked_by(key) for key in options.blackboard}
    for by in dict.fromkeys(asked.values()):
        loaded.set_blackboard(
            {key: value for key, value in options.blackboard.items() if asked[key] == by}, asked_by=by
        )
    setup = ProviderSetup(
        clock=make_clock(clock or "wall"), options=options.options, clock_name=clock, variant=options.variant
    )
    resources = provide_resources(loaded.resource_users(), setup)
    recorder = None
    try:
        supplied, clock_kind = resource_clock(resources, clock)
        built = loaded.build(RunContext(clock=supplied or setup.clock, resources=resources))
        listeners: list[Callable[[Record], None]] = (
            [] if quiet else [ProgressPrinter(built, out, verbose=verbose)]
        )
        if options.record is not None:
            recorder = _recorder(
                options.record, supplied or setup.clock, clock_kind, options.record_cloud_step, resources
            )
            listeners.append(recorder.tick_record)
        if not quiet:
            bars = [
                resource.progress() for resource in resources.values() if isinstance(resource, ShowsProgress)
            ]
            listeners += bars or [tick_bar(out)]
        if watch is not None:
            listeners += watch(built, resources)
        try:
            writer = TickLogWriter(
                log_path,
                built,
                clock_kind=clock_kind,
                run=options.record_fields(met_world=bool(resources)),
                listeners=listeners,
                messages=[
                    resource.log_messages
                    for resource in resources.values()
                    if isinstance(resource, LogsMessages)
                ],
            )
        except OSError as error:
            raise PegbtError(f"cannot write the tick log: {error.strerror}", file=log_path) from None
        period = options.period
        if not quiet:
            print(f"running {tree} (period {period:g} s, {clock_kind} clock); tick log {log_path}", file=out)
        result = run(built, period=period, timeout=options.timeout, log=writer)
        reports = {
            name: resource.report() for name, resource in resources.items() if isinstance(resource, Reports)
        }
        reports = {name: report for name, report in reports.items() if report is not None}
    finally:
        try:
            if recorder is not None:
                recorder.close()
        finally:
            close_resources(resources)
    return RunOutput(result, log_path, reports)


def _recorder(
    path: str | Path, clock: Any, clock_kind: str, cloud_step: int, resources: Mapping[str, Any]
) -> Any:
    """A `WireRecorder` on every resource's link (imported here: zenoh and mcap only when recording)."""
    from pegbt.transport.link import Link
    from pegbt.transport.recorder import WireRecorder

    simulated = bool(getattr(clock, "lockstep", False))
    recorder = WireRecorder(
        path, clock.now, simulated=simulated, clock_kind=clock_kind, cloud_step=cloud_step
    )
    for resource in resources.values():
        if isinstance(getattr(resource, "link", None), Link):
            recorder.attach(resource.link)
        if getattr(resource, "wire", None) is not None:  # a CRTK robot: its topics, from whoever sends them
            recorder.listen(resource.wire, resource.ros2_topics)
    return recorder
