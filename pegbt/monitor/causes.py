"""The failures the page marks: the first cause `pegbt log why` names, and the first cause of each failure
the tree gave up on (`pegbt.executive.causes.failure_chains`), as node ids with tick, time and feedback."""

from __future__ import annotations

from typing import Any

from pegbt.executive.causes import Timeline, failure_chains
from pegbt.executive.logfile import TickLog


def marked_causes(log: TickLog) -> dict[str, Any]:
    """`first`: the run's first cause (None unless the run failed); `given_up`: each given-up chain's first cause."""
    timeline = Timeline(log)
    first = None
    root_failure = timeline.final_failure(0)
    if log.end and log.end["outcome"] == "failure" and root_failure is not None:
        origin = timeline.first_origin(root_failure)
        first = _mark(log, origin.node, origin.n, origin.t, origin.feedback)
    ids = {node["path"]: node["id"] for node in log.nodes}
    given_up = []
    for chain in failure_chains(log, timeline):
        if chain.handled == "given up":
            step = chain.first_cause
            given_up.append({**_mark(log, ids[step.path], step.n, step.t, step.feedback), "by": chain.by})
    return {"outcome": log.outcome, "first": first, "given_up": given_up}


def _mark(log: TickLog, node: int, n: int, t: float, feedback: str) -> dict[str, Any]:
    return {"node": node, "path": log.nodes[node]["path"], "n": n, "t": t, "feedback": feedback}
