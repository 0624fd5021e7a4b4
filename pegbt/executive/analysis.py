"""What happened in a run, from its tick log: summary, causal chain of a failure, and replay.

`why` starts at the root's final failure and descends: a node failed because of every child that failed
since the node last finished (a selector's alternatives, a retry's attempts, a recover node's tries, not
only the latest); a node with no such child failed on its own (a leaf, a timeout, a guard whose condition
stopped holding). For each of those origins it shows the time, the feedback message and the blackboard
values the node reads. Failures the tree absorbed are listed too: each recovery that ran, each failure
a selector or a retry got over, and each failure it gave up on (a `recover` node out of retries, a `force_success` over a failed child) so the
run could go on, traced back to its first cause: the earliest origin in its chain that is not control
flow (a blackboard check that steered the tree, a failure raised on purpose), with what followed. Last,
each transfer the run began, placed or the phase it failed in (`pegbt.executive.phases`).
`pegbt.executive.causes` has the same chains as data, for tools that check them (`pegbt eval`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from pegbt.errors import PegbtError
from pegbt.executive.causes import Recovery, Timeline, failure_chains, fallbacks, recoveries
from pegbt.executive.logfile import TickLog, Transition, message_line
from pegbt.executive.phases import begun_transfers, transfer_outcomes

SHOWN_WIDTH = 160  # characters of a blackboard value shown beside a failure
MESSAGES_SHOWN = 10  # a robot's last errors and warnings listed by `pegbt log summary`
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
    world = log.run.get("world")
    world = world if isinstance(world, dict) else {}
    lines = [
        f"tree:     {log.header.get('tree')}",
        f"run:      variant {log.variant}, condition {log.condition or 'not recorded'}"
        + (f", {world.get('physics')} physics ({world.get('speed')})" if world.get("physics") else ""),
        f"started:  {log.header.get('start_time')} ({log.header.get('clock')} clock)",
        f"outcome:  {log.outcome}",
        f"duration: {log.last_t:.3f} s over {log.last_n} ticks",
    ]
    if log.crash:
        lines.append(f"crash:    {log.crash.get('error')}")
    current = [message for message in log.messages if not message.get("before_run")]
    if log.messages:
        levels = [message["level"] for message in current]
        history = len(log.messages) - len(current)
        lines.append(
            "robot:    "
            + ", ".join(
                [f"{levels.count(level)} {level}" for level in sorted(set(levels))]
                + ([f"{history} from before this run"] if history else [])
            )
        )
        lines += [
            f"  {m['t']:8.3f} s  {m['level']:<7}  {message_line(m)}"
            for m in [m for m in current if m["level"] in ("error", "warning")][-MESSAGES_SHOWN:]
        ]
    lines += [""] + _table(log, stats, [node["id"] for node in log.nodes])
    ranked = sorted(leaves, key=lambda node: stats[node].running_time, reverse=True)[:slowest]
    lines += ["", "slowest leaves (time running):"]
    lines += [
        f"  {stats[node].running_time:8.3f} s (longest {stats[node].longest_run:.3f} s)  {log.nodes[node]['path']}"
        for node in ranked
    ]
    return "\n".join(lines)


def result_table(log: TickLog) -> str:
    """A short table of the run for the end of `pegbt run`: outcome, and how each leaf fared."""
    stats = node_stats(log)
    shown = [node["id"] for node in log.nodes if not log.children(node["id"]) or node["type"] == "subtree"]
    return "\n".join(
        [f"outcome: {log.outcome} in {log.last_t:.3f} s, {log.last_n} ticks"] + _table(log, stats, shown)
    )


def _table(log: TickLog, stats: list[NodeStats], nodes: list[int]) -> list[str]:
    """Rows of node name (indented by depth) and its counts."""
    names = {node: "  " * log.depth(node) + log.nodes[node]["name"] for node in nodes}
    width = max(len(name) for name in names.values())
    rows = [f"{'node':<{width}}  {'ok':>4} {'fail':>4} {'halt':>4} {'running s':>10}"]
    for node in nodes:
        entry = stats[node]
        rows.append(
            f"{names[node]:<{width}}  {entry.successes:>4} {entry.failures:>4} {entry.halts:>4} {entry.running_time:>10.3f}"
        )
    return rows


def why(log: TickLog) -> str:
    """The causal chain of the run's failure (or its timeout / interruption), the recoveries that ran, and
    each failure the tree gave up on, from its first cause."""
    timeline = Timeline(log)
    lines = [f"outcome: {log.outcome} at t={log.last_t:.3f} s (tick {log.last_n})"]
    root_failure = timeline.final_failure(0)
    if log.end and log.end["outcome"] == "failure" and root_failure is not None:
        first = timeline.first_origin(root_failure)
        lines.append(
            f"first cause: {log.nodes[first.node]['path']} at t={first.t:.3f} s: {first.feedback or 'no feedback'}"
        )
        lines.append("causal chain (root failure down to the leaves that caused it):")
        _explain(timeline, root_failure, 1, lines)
    elif log.end is None or log.end["outcome"] != "success":
        lines.append("running when the run stopped:")
        for change in log.transitions:
            if change.halted and change.before == "RUNNING" and not log.children(change.node):
                lines.append(
                    f"  {log.nodes[change.node]['path']}  ({change.feedback or 'no feedback'})  halted: {change.halted}"
                )
        if not any(change.halted for change in log.transitions):
            for change in _still_running_leaves(log):
                lines.append(
                    f"  {log.nodes[change.node]['path']}  ({change.feedback or 'no feedback'})  never halted: "
                    "the log ends"
                )
        if log.crash:
            lines.append(f"crash: {log.crash.get('error')}")
    else:
        lines.append(
            "the run succeeded"
            + (
                "; failures below were recovered"
                if any(c.after == "FAILURE" for c in log.transitions)
                else ""
            )
        )
    lines += _recoveries(timeline)
    lines += _fallback_lines(timeline)
    lines += _given_up_lines(log, timeline)
    lines += _transfer_lines(log)
    return "\n".join(lines)


def _transfer_lines(log: TickLog) -> list[str]:
    """Each transfer the run began, as the log alone tells it: placed, or the phase it failed in."""
    outcomes = transfer_outcomes(log)
    if not outcomes:
        return []
    lines = [
        f"transfers ({sum(o.succeeded for o in outcomes)} of {len(outcomes)} placed, as the log tells; a failure "
        "by the phase of its first cause):"
    ]
    for outcome, node in zip(outcomes, begun_transfers(log)):
        params = node["params"]
        said = "placed" if outcome.succeeded else f"failed at {outcome.phase or 'an unnamed phase'}"
        lines.append(
            f"  {outcome.transfer}: {params.get('arms')} peg {params.get('pick')} → {params.get('place')}: {said}"
        )
    return lines


def _still_running_leaves(log: TickLog) -> list[Transition]:
    """The last change of each leaf still RUNNING where the log ends (a run killed with no halt record)."""
    last: dict[int, Transition] = {}
    for change in log.transitions:
        last[change.node] = change
    return [
        change
        for node, change in sorted(last.items())
        if change.after == "RUNNING" and not log.children(node)
    ]


def _explain(timeline: Timeline, failure: Transition, depth: int, lines: list[str]) -> None:
    """The failure and its causes, depth first (a stack, not recursion: a chain may be long)."""
    log = timeline.log
    pending = [(failure, depth)]
    while pending:
        failure, depth = pending.pop()
        node = log.nodes[failure.node]
        causes = timeline.causes(failure)
        indent = "  " * depth
        origin = "" if causes else "  <- failed here"
        feedback = f": {failure.feedback}" if failure.feedback else ""
        lines.append(
            f"{indent}{node['path']} ({node['type']}) failed at t={failure.t:.3f} s, tick {failure.n}{feedback}{origin}"
        )
        lines.append(f"{indent}  defined at {node['source']}")
        if not causes:
            _origin_details(timeline, failure, indent, lines)
        pending += [(cause, depth + 1) for cause in reversed(causes)]


def _origin_details(timeline: Timeline, failure: Transition, indent: str, lines: list[str]) -> None:
    log = timeline.log
    node = log.nodes[failure.node]
    if node["reads"]:
        values = log.blackboard_at(failure.n)
        shown = ", ".join(
            f"{key}={_short(values[key]) if key in values else '<unset>'}" for key in node["reads"]
        )
        lines.append(f"{indent}  blackboard it reads: {shown}")
    for child in log.children(failure.node):
        for change in timeline.by_node[child]:
            if change.n == failure.n and change.before == "RUNNING" and change.after == "INVALID":
                lines.append(
                    f"{indent}  halted child: {log.nodes[child]['path']} ({change.feedback or 'no feedback'})"
                )


def _short(value: Any, width: int = SHOWN_WIDTH) -> str:
    """A blackboard value as JSON (an object the log kept as its repr, as that repr), cut to `width`
    characters: a list of block estimates would fill a screen."""
    text = (
        " ".join(value["repr"].split())
        if isinstance(value, dict) and list(value) == ["repr"]
        else json.dumps(value)
    )
    return text if len(text) <= width else text[: width - 3] + "..."


def _recoveries(timeline: Timeline) -> list[str]:
    log = timeline.log
    lines = []
    for recovery in recoveries(timeline):
        origin = recovery.origin
        lines.append(
            f"  {log.nodes[recovery.node]['path']}: main failed at t={recovery.failed_t:.3f} s "
            f"({log.nodes[origin.node]['name']}: {origin.feedback or 'no feedback'}); "
            f"recovery {recovery.tried.after.lower()} at t={recovery.tried.t:.3f} s; {_verdict(recovery)}"
        )
    return (["recoveries:"] + lines) if lines else ["recoveries: none ran"]


def _fallback_lines(timeline: Timeline) -> list[str]:
    log = timeline.log
    lines = [
        f"  {log.nodes[found.node]['path']}: {log.nodes[found.origin.node]['name']} failed at t={found.origin.t:.3f} s "
        f"({found.origin.feedback or 'no feedback'}); it went on and succeeded at t={found.succeeded.t:.3f} s"
        for found in fallbacks(timeline)
    ]
    return (["got over by another alternative or attempt:"] + lines) if lines else []


def _given_up_lines(log: TickLog, timeline: Timeline) -> list[str]:
    """Per failure the tree gave up on: the node that gave up, the first cause of its chain (where, why, with
    which blackboard values) and every failure of the chain after it."""
    lines = []
    for chain in failure_chains(log, timeline):
        if chain.handled != "given up":
            continue
        first = chain.first_cause
        lines.append(f"  {chain.by}: gave up at t={chain.t:.3f} s")
        for step in chain.steps:
            where = step.path.removeprefix(chain.by + "/")
            if step is first:
                lines.append(
                    f"    first cause: {where} ({step.type}) failed at t={step.t:.3f} s, tick {step.n}: {step.feedback or 'no feedback'}"
                )
                lines.append(f"      defined at {step.source}")
                if step.reads:
                    lines.append(
                        f"      blackboard it read: {', '.join(f'{key}={_short(value)}' for key, value in step.reads)}"
                    )
                if step.halted:
                    lines.append(f"      it halted: {'; '.join(step.halted)}")
            else:
                lines.append(
                    f"    {'then' if step.t >= first.t else 'before'}: {where} at t={step.t:.3f} s: {step.feedback or 'no feedback'}"
                )
    return (["given up (the tree went on without it):"] + lines) if lines else []


def _verdict(recovery: Recovery) -> str:
    if recovery.tried.after == "FAILURE":
        return "the recovery failed, so the recover node failed"
    if recovery.then == "succeeded":
        return f"main was retried and succeeded at t={recovery.then_t:.3f} s: it helped"
    if recovery.then == "failed":
        return f"main was retried and failed again at t={recovery.then_t:.3f} s: it did not help"
    return "main was retried; the run ended before it finished"


def replay(log: TickLog, *, tick: int | None = None, time: float | None = None) -> str:
    """Every node's status (and feedback) after tick `tick`, or at executive time `time`, with the blackboard."""
    if tick is None:
        tick = (
            max((change.n for change in log.transitions if change.t <= time), default=0)
            if time is not None
            else log.last_n
        )
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
