"""What happened in a run, from its tick log: summary, causal chain of a failure, and replay.

`why` starts at the root's final failure and descends: a node failed because of the children whose
latest change before that moment, since the node last started, was to FAILURE; a node with no such
child failed on its own (a leaf, a timeout, a guard whose condition stopped holding). For each of
those origins it shows the time, the feedback message and the blackboard values the node reads.
Failures the tree absorbed are listed too: each recovery that ran, and each failure it gave up on (a
`recover` node out of retries, a `force_success` over a failed child) so the run could go on.
`failure_steps` returns the same origins as data, for tools that check them (`pegbt eval`).
"""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import dataclass

from pegbt.errors import PegbtError
from pegbt.executive.logfile import TickLog, Transition

_MARKS = {"SUCCESS": "[S]", "FAILURE": "[F]", "RUNNING": "[R]", "INVALID": "[ ]"}


@dataclass
class NodeStats:
    successes: int = 0
    failures: int = 0
    halts: int = 0
    running_time: float = 0.0
    longest_run: float = 0.0


def node_stats(log: TickLog) -> list[NodeStats]:
    """Per node: successes, failures, halts, total and longest time running."""
    stats = [NodeStats() for _ in log.nodes]
    started: dict[int, float] = {}
    for change in log.transitions:
        entry = stats[change.node]
        if change.after == "SUCCESS":
            entry.successes += 1
        elif change.after == "FAILURE":
            entry.failures += 1
        elif change.after == "INVALID" and change.before == "RUNNING":
            entry.halts += 1
        if change.after == "RUNNING" and change.before != "RUNNING":
            started[change.node] = change.t
        elif change.before == "RUNNING" and change.node in started:
            _close(entry, change.t - started.pop(change.node))
    for node, since in started.items():
        _close(stats[node], log.last_t - since)
    return stats


def _close(entry: NodeStats, duration: float) -> None:
    entry.running_time += duration
    entry.longest_run = max(entry.longest_run, duration)


def summary(log: TickLog, slowest: int = 5) -> str:
    """Outcome, duration, ticks, per-node counts and the slowest leaves, as text."""
    stats = node_stats(log)
    leaves = [node["id"] for node in log.nodes if not log.children(node["id"])]
    lines = [
        f"tree:     {log.header.get('tree')}",
        f"started:  {log.header.get('start_time')} ({log.header.get('clock')} clock)",
        f"outcome:  {log.outcome}",
        f"duration: {log.last_t:.3f} s over {log.last_n} ticks",
    ]
    if log.crash:
        lines.append(f"crash:    {log.crash.get('error')}")
    lines += [""] + _table(log, stats, [node["id"] for node in log.nodes])
    ranked = sorted(leaves, key=lambda node: stats[node].running_time, reverse=True)[:slowest]
    lines += ["", "slowest leaves (time running):"]
    lines += [f"  {stats[node].running_time:8.3f} s (longest {stats[node].longest_run:.3f} s)  {log.nodes[node]['path']}" for node in ranked]
    return "\n".join(lines)


def result_table(log: TickLog) -> str:
    """A short table of the run for the end of `pegbt run`: outcome, and how each leaf fared."""
    stats = node_stats(log)
    shown = [node["id"] for node in log.nodes if not log.children(node["id"]) or node["type"] == "subtree"]
    return "\n".join([f"outcome: {log.outcome} in {log.last_t:.3f} s, {log.last_n} ticks"] + _table(log, stats, shown))


def _table(log: TickLog, stats: list[NodeStats], nodes: list[int]) -> list[str]:
    """Rows of node name (indented by depth) and its counts."""
    names = {node: "  " * log.depth(node) + log.nodes[node]["name"] for node in nodes}
    width = max(len(name) for name in names.values())
    rows = [f"{'node':<{width}}  {'ok':>4} {'fail':>4} {'halt':>4} {'running s':>10}"]
    for node in nodes:
        entry = stats[node]
        rows.append(f"{names[node]:<{width}}  {entry.successes:>4} {entry.failures:>4} {entry.halts:>4} {entry.running_time:>10.3f}")
    return rows


class _Timeline:
    """Transitions per node, for questions like "what was this child's last change before seq s"."""

    def __init__(self, log: TickLog) -> None:
        self.log = log
        self.by_node: dict[int, list[Transition]] = defaultdict(list)
        for change in log.transitions:
            self.by_node[change.node].append(change)

    def last_before(self, node: int, seq: int) -> Transition | None:
        found = None
        for change in self.by_node[node]:
            if change.seq >= seq:
                break
            found = change
        return found

    def started_before(self, node: int, seq: int) -> int:
        """Seq of the node's last start (a change to RUNNING, or its previous finish) before `seq`; -1 if none."""
        start = -1
        for change in self.by_node[node]:
            if change.seq >= seq:
                break
            if change.after == "RUNNING" and change.before != "RUNNING" or change.after in ("SUCCESS", "FAILURE", "INVALID"):
                start = change.seq
        return start

    def final_failure(self, node: int) -> Transition | None:
        failures = [change for change in self.by_node[node] if change.after == "FAILURE"]
        return failures[-1] if failures else None


@dataclass(frozen=True)
class FailureStep:
    """A node that failed on its own (the origin of a failure) and how the tree took that failure:
    `run` (the run failed), `recovered` (a recovery ran), `given up` (a recover node ran out of retries,
    or a force_success absorbed it); `by` is the path of the node that took it."""

    path: str
    name: str
    type: str
    t: float
    feedback: str
    handled: str
    by: str


def failure_steps(log: TickLog) -> list[FailureStep]:
    """Every failure origin `why` names, in time order."""
    timeline = _Timeline(log)
    steps = []
    root_failure = timeline.final_failure(0)
    if log.end and log.end["outcome"] == "failure" and root_failure is not None:
        steps += [_step(log, origin, "run", 0) for origin in _origins(timeline, root_failure)]
    steps += [_step(log, origin, "recovered", node) for node, origin, _ in _recovered(timeline)]
    steps += [_step(log, origin, "given up", node) for node, origin in _given_up(timeline)]
    return sorted(steps, key=lambda step: step.t)


def _step(log: TickLog, origin: Transition, handled: str, by: int) -> FailureStep:
    node = log.nodes[origin.node]
    return FailureStep(node["path"], node["name"], node["type"], origin.t, origin.feedback, handled, log.nodes[by]["path"])


def _origins(timeline: _Timeline, failure: Transition) -> list[Transition]:
    """Every node down the causal chain of `failure` that failed on its own."""
    causes = _causes(timeline, failure)
    return [origin for cause in causes for origin in _origins(timeline, cause)] if causes else [failure]


def why(log: TickLog) -> str:
    """The causal chain of the run's failure (or its timeout / interruption), and the recoveries that ran."""
    timeline = _Timeline(log)
    lines = [f"outcome: {log.outcome} at t={log.last_t:.3f} s (tick {log.last_n})"]
    root_failure = timeline.final_failure(0)
    if log.end and log.end["outcome"] == "failure" and root_failure is not None:
        lines.append("causal chain (root failure down to the leaves that caused it):")
        _explain(timeline, root_failure, 1, lines)
    elif log.end is None or log.end["outcome"] != "success":
        lines.append("running when the run stopped:")
        for change in log.transitions:
            if change.halted and change.before == "RUNNING" and not log.children(change.node):
                lines.append(f"  {log.nodes[change.node]['path']}  ({change.feedback or 'no feedback'})  halted: {change.halted}")
        if log.crash:
            lines.append(f"crash: {log.crash.get('error')}")
    else:
        lines.append("the run succeeded" + ("; failures below were recovered" if any(c.after == "FAILURE" for c in log.transitions) else ""))
    lines += _recoveries(timeline)
    lines += _given_up_lines(timeline)
    return "\n".join(lines)


def _causes(timeline: _Timeline, failure: Transition) -> list[Transition]:
    """The children's failures that made `failure` happen (their latest change, since the node started)."""
    start = timeline.started_before(failure.node, failure.seq)
    causes = []
    for child in timeline.log.children(failure.node):
        last = timeline.last_before(child, failure.seq)
        if last is not None and last.after == "FAILURE" and last.seq > start:
            causes.append(last)
    return causes


def _origin(timeline: _Timeline, failure: Transition) -> Transition:
    """The first node down the causal chain of `failure` that failed on its own (with its own reason)."""
    causes = _causes(timeline, failure)
    while causes:
        failure = causes[0]
        causes = _causes(timeline, failure)
    return failure


def _explain(timeline: _Timeline, failure: Transition, depth: int, lines: list[str]) -> None:
    log = timeline.log
    node = log.nodes[failure.node]
    causes = _causes(timeline, failure)
    indent = "  " * depth
    origin = "" if causes else "  <- failed here"
    feedback = f": {failure.feedback}" if failure.feedback else ""
    lines.append(f"{indent}{node['path']} ({node['type']}) failed at t={failure.t:.3f} s, tick {failure.n}{feedback}{origin}")
    lines.append(f"{indent}  defined at {node['source']}")
    if not causes:
        _origin_details(timeline, failure, indent, lines)
    for cause in causes:
        _explain(timeline, cause, depth + 1, lines)


def _origin_details(timeline: _Timeline, failure: Transition, indent: str, lines: list[str]) -> None:
    log = timeline.log
    node = log.nodes[failure.node]
    if node["reads"]:
        values = log.blackboard_at(failure.n)
        shown = ", ".join(f"{key}={json.dumps(values[key]) if key in values else '<unset>'}" for key in node["reads"])
        lines.append(f"{indent}  blackboard it reads: {shown}")
    for child in log.children(failure.node):
        for change in timeline.by_node[child]:
            if change.n == failure.n and change.before == "RUNNING" and change.after == "INVALID":
                lines.append(f"{indent}  halted child: {log.nodes[child]['path']} ({change.feedback or 'no feedback'})")


def _recovered(timeline: _Timeline) -> list[tuple[int, Transition, tuple[Transition, Transition, int]]]:
    """Per main failure a recovery answered: the recover node, the failure's origin, and (the main's
    failure, the recovery's outcome, the main child) for the verdict."""
    log = timeline.log
    found = []
    for node in log.nodes:
        if node["type"] != "recover":
            continue
        main, recovery = log.children(node["id"])
        for change in timeline.by_node[main]:
            if change.after != "FAILURE":
                continue
            tried = next((c for c in timeline.by_node[recovery] if c.seq > change.seq and c.after in ("SUCCESS", "FAILURE")), None)
            if tried is None or timeline.last_before(main, tried.seq) is not change:
                continue  # no recovery answered this failure (none left, or the run stopped)
            found.append((node["id"], _origin(timeline, change), (change, tried, main)))
    return found


def _reason(log: TickLog, origin: Transition, failure: Transition) -> str:
    reason = origin.feedback or "no feedback"
    return reason if origin is failure else f"{log.nodes[origin.node]['name']}: {reason}"


def _recoveries(timeline: _Timeline) -> list[str]:
    log = timeline.log
    lines = []
    for node, origin, (change, tried, main) in _recovered(timeline):
        lines.append(f"  {log.nodes[node]['path']}: main failed at t={change.t:.3f} s ({_reason(log, origin, change)}); "
                     f"recovery {tried.after.lower()} at t={tried.t:.3f} s; {_verdict(timeline, main, tried)}")
    return (["recoveries:"] + lines) if lines else ["recoveries: none ran"]


def _given_up(timeline: _Timeline) -> list[tuple[int, Transition]]:
    """Failures the tree absorbed to go on: a recover node that failed (retries spent) and a force_success
    over a failed child, each with its origin; one entry per origin (the innermost node that gave up)."""
    log = timeline.log
    found, seen = [], set()
    for node in reversed(log.nodes):  # children before their ancestors
        if node["type"] == "recover":
            failures = [c for c in timeline.by_node[node["id"]] if c.after == "FAILURE"]
        elif node["type"] == "force_success":
            failures = [c for child in log.children(node["id"]) for c in timeline.by_node[child] if c.after == "FAILURE"]
        else:
            continue
        for failure in failures:
            origin = _origin(timeline, failure)
            if origin is failure and node["type"] == "recover":
                # main failed again as soon as it was retried, within one tick: the log kept its first failure
                last = timeline.last_before(log.children(node["id"])[0], failure.seq)
                origin = _origin(timeline, last) if last is not None and last.after == "FAILURE" else failure
            if origin.seq not in seen:
                seen.add(origin.seq)
                found.append((node["id"], origin))
    return sorted(found, key=lambda item: item[1].seq)


def _given_up_lines(timeline: _Timeline) -> list[str]:
    log = timeline.log
    lines = [f"  {log.nodes[node]['path']}: gave up at t={origin.t:.3f} s ({log.nodes[origin.node]['name']}: "
             f"{origin.feedback or 'no feedback'})" for node, origin in _given_up(timeline)]
    return (["given up (the tree went on without it):"] + lines) if lines else []


def _verdict(timeline: _Timeline, main: int, recovery: Transition) -> str:
    if recovery.after == "FAILURE":
        return "the recovery failed, so the recover node failed"
    then = next((c for c in timeline.by_node[main] if c.seq > recovery.seq and c.after in ("SUCCESS", "FAILURE")), None)
    if then is None:
        return "main was retried; the run ended before it finished"
    if then.after == "SUCCESS":
        return f"main was retried and succeeded at t={then.t:.3f} s: it helped"
    return f"main was retried and failed again at t={then.t:.3f} s: it did not help"


def replay(log: TickLog, *, tick: int | None = None, time: float | None = None) -> str:
    """Every node's status (and feedback) after tick `tick`, or at executive time `time`, with the blackboard."""
    if tick is None:
        tick = max((change.n for change in log.transitions if change.t <= time), default=0) if time is not None else log.last_n
    elif not 0 <= tick <= log.last_n:
        raise PegbtError(f"the log has ticks 0 to {log.last_n}, not {tick}", file=log.path, field="--tick")
    status = ["INVALID"] * len(log.nodes)
    feedback = [""] * len(log.nodes)
    t = 0.0
    for change in log.transitions:
        if change.n > tick:
            break
        status[change.node], feedback[change.node], t = change.after, change.feedback, change.t
    lines = [f"after tick {tick} of {log.last_n} (last change at t={t:.3f} s)"]
    for node in log.nodes:
        note = f"  -- {feedback[node['id']]}" if feedback[node["id"]] else ""
        lines.append(f"{'    ' * log.depth(node['id'])}{_MARKS[status[node['id']]]} {node['name']}{note}")
    lines.append("blackboard:")
    lines += [f"  {key} = {json.dumps(value)}" for key, value in sorted(log.blackboard_at(tick).items())]
    return "\n".join(lines)
