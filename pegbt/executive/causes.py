"""Why nodes failed, from a tick log: the child failures behind a failure, the origins down its chain, the
recoveries that ran, the failures a selector or a retry got over, and the chains of failures the tree did
not get over, each with its first cause.

A node failed because of every child that failed since the node last finished: all of a selector's
alternatives, each attempt of a retry, each try of a recover node's main and its recovery, not only the
latest. A node with no such child failed on its own: an origin (a leaf, a timeout, a guard whose condition
stopped holding). The origins of a failure are the descendants that failed on their own in its activation
and whose failure reached it: every node between failed next (a selector that went on to an alternative
that succeeded, a retry whose next attempt succeeded, absorbed it). A node that fails again within one
tick keeps its status, so the log has no change for it; it is taken to have failed again.

The first cause of a chain is its earliest origin that is not control flow: a blackboard check that
steered the tree, or a failure raised on purpose, only echoes a failure before it (a receiver that finds
the offer withdrawn, a branch that records a failure and fails again). A chain of echoes alone (the
failure was elsewhere: the other arm's subtree) starts at its earliest echo.
"""

from __future__ import annotations

from bisect import bisect_right
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from pegbt.behaviours.leaves import STEERING
from pegbt.executive.logfile import TickLog, Transition

CONTROL_FLOW = frozenset({"check_blackboard", "force_failure", "inverter", *STEERING})
ABSORBERS = frozenset(
    {"selector", "retry"}
)  # nodes that get over a child's failure by another child or attempt
FINISHED = ("SUCCESS", "FAILURE", "INVALID")


class Timeline:
    """Transitions per node, for questions like "what was this child's last change before seq s"."""

    def __init__(self, log: TickLog) -> None:
        self.log = log
        self.by_node: dict[int, list[Transition]] = defaultdict(list)
        for change in log.transitions:
            self.by_node[change.node].append(change)
        self._seqs = {node: [change.seq for change in changes] for node, changes in self.by_node.items()}
        self.children: dict[int, list[int]] = defaultdict(list)
        for node in log.nodes:
            if node["parent"] is not None:
                self.children[node["parent"]].append(node["id"])
        self._origins: dict[int, list[Transition]] = {}

    def last_before(self, node: int, seq: int) -> Transition | None:
        index = bisect_right(self._seqs.get(node, []), seq - 1)
        return self.by_node[node][index - 1] if index else None

    def first_after(self, node: int, seq: int) -> Transition | None:
        index = bisect_right(self._seqs.get(node, []), seq)
        changes = self.by_node[node]
        return changes[index] if index < len(changes) else None

    def finished_before(self, node: int, seq: int) -> int:
        """Seq of the node's last finish (a change to SUCCESS, FAILURE or INVALID) before `seq`; -1 if none.
        Its children's changes after that belong to its next activation, even those logged in the tick it
        started, before its own change to RUNNING (a tick logs children first)."""
        index = bisect_right(self._seqs.get(node, []), seq - 1)
        return next(
            (change.seq for change in reversed(self.by_node[node][:index]) if change.after in FINISHED), -1
        )

    def final_failure(self, node: int) -> Transition | None:
        failures = [change for change in self.by_node[node] if change.after == "FAILURE"]
        return failures[-1] if failures else None

    def descendants(self, node: int) -> list[int]:
        found, stack = [], list(self.children[node])
        while stack:
            found.append(stack.pop())
            stack += self.children[found[-1]]
        return found

    def causes(self, failure: Transition) -> list[Transition]:
        """The children's failures that made `failure` happen, in order: every one since the node last finished;
        if none was logged, a child whose latest change was to FAILURE (it failed again within one tick)."""
        children = self.children[failure.node]
        finish = self.finished_before(failure.node, failure.seq)
        found = [
            change
            for child in children
            for change in self.by_node[child]
            if finish < change.seq < failure.seq and change.after == "FAILURE"
        ]
        if not found:
            latest = (self.last_before(child, failure.seq) for child in children)
            found = [change for change in latest if change is not None and change.after == "FAILURE"]
        return sorted(found, key=lambda change: change.seq)

    def origins(self, failure: Transition) -> list[Transition]:
        """The origins of `failure` (see the module docstring), in the order they failed; the failure itself
        if its node failed on its own."""
        if failure.seq not in self._origins:
            found = self.origins_between(
                failure.node, self.finished_before(failure.node, failure.seq), failure.seq
            )
            self._origins[failure.seq] = found or [failure]
        return self._origins[failure.seq]

    def origins_between(self, top: int, after: int, before: int) -> list[Transition]:
        """`top` and its descendants that failed on their own between seqs `after` and `before`, and whose
        failure reached `top`'s child on their way (each node between failed next)."""
        found = [
            change
            for node in [top, *self.descendants(top)]
            for change in self.by_node[node]
            if after < change.seq < before
            and change.after == "FAILURE"
            and self.failed_on_its_own(change)
            and self._reached(change, top, before)
        ]
        return sorted(found, key=lambda change: change.seq)

    def first_origin(self, failure: Transition) -> Transition:
        """The first cause down the chain of `failure` (see the module docstring)."""
        return self.first_of(self.origins(failure))

    def first_of(self, origins: Sequence[Transition]) -> Transition:
        return next(
            (origin for origin in origins if self.log.nodes[origin.node]["type"] not in CONTROL_FLOW),
            origins[0],
        )

    def next_finish(self, node: int, after: int, before: int) -> Transition | None:
        """The node's first finish (a change to SUCCESS, FAILURE or INVALID) between seqs `after` and `before`."""
        index = bisect_right(self._seqs.get(node, []), after)
        return next(
            (
                change
                for change in self.by_node[node][index:]
                if change.seq < before and change.after in FINISHED
            ),
            None,
        )

    def failed_on_its_own(self, failure: Transition) -> bool:
        return not self.children[failure.node] or not self.causes(failure)

    def _reached(self, failure: Transition, top: int, before: int) -> bool:
        """Whether every node between `failure`'s node and `top` failed next (before seq `before`): its first
        finish after the failure is a failure, or it has none and was failed already (it failed again within a
        tick). A node that went on running (a selector to its next child, a retry to its next attempt) decides
        at its finish; one that succeeded or was halted absorbed the failure."""
        if failure.node == top:
            return True
        node = self.log.nodes[failure.node]["parent"]
        while node is not None and node != top:
            finish = self.next_finish(node, failure.seq, before)
            if finish is None:
                latest = self.last_before(node, before)
                if latest is None or latest.after != "FAILURE":
                    return False
            elif finish.after != "FAILURE":
                return False
            node = self.log.nodes[node]["parent"]
        return node == top


@dataclass(frozen=True)
class Fallback:
    """A failure a selector or a retry got over: the origin, the node that absorbed it, and its success."""

    node: int
    origin: Transition
    succeeded: Transition


def fallbacks(timeline: Timeline) -> list[Fallback]:
    """Every failure (of a node that failed on its own, not control flow) that reached a selector or a retry
    which then succeeded: an alternative or another attempt made up for it. In time order. A failure a recover
    node gave up on is not one, even if a selector then went on (to give the block up)."""
    log, end = timeline.log, len(timeline.log.transitions)
    found = []
    for change in log.transitions:
        if (
            change.after != "FAILURE"
            or log.nodes[change.node]["type"] in CONTROL_FLOW
            or not timeline.failed_on_its_own(change)
        ):
            continue
        node = log.nodes[change.node]["parent"]
        while node is not None:
            finish = timeline.next_finish(node, change.seq, end)
            if (
                finish is None
                or finish.after == "INVALID"
                or finish.after == "FAILURE"
                and log.nodes[node]["type"] == "recover"
            ):
                break  # halted, or given up (a chain tells it)
            if finish.after == "SUCCESS":
                if log.nodes[node]["type"] in ABSORBERS:
                    found.append(Fallback(node, change, finish))
                break
            node = log.nodes[node]["parent"]
    return found


@dataclass(frozen=True)
class Recovery:
    """One run of a recover node's recovery: the main failure it answered (when, and the first cause), how
    the recovery ended, and what main did next ("succeeded", "failed" at `then_t`, or "" if it never finished)."""

    node: int
    failed_t: float
    origin: Transition
    tried: Transition
    then: str
    then_t: float | None


def recoveries(timeline: Timeline) -> list[Recovery]:
    """Every recovery a recover node ran, in the order they ran. Main failed when its recovery began; a main
    that failed again within one tick, the same way, left no change in the log: its last cause stands."""
    found = []
    for node in timeline.log.nodes:
        if node["type"] != "recover":
            continue
        main, recovery = timeline.children[node["id"]]
        last: list[Transition] = []
        for tried in (
            change for change in timeline.by_node[recovery] if change.after in ("SUCCESS", "FAILURE")
        ):
            start = max(
                timeline.finished_before(node["id"], tried.seq), timeline.finished_before(recovery, tried.seq)
            )
            began = timeline.first_after(recovery, start)
            failed = timeline.origins_between(main, start, tried.seq) or last
            if began is None or not failed:
                continue
            last = failed
            then, then_t = _next_outcome(timeline, node["id"], main, tried)
            found.append(Recovery(node["id"], began.t, timeline.first_of(failed), tried, then, then_t))
    return sorted(found, key=lambda recovery: recovery.tried.seq)


def _next_outcome(timeline: Timeline, node: int, main: int, tried: Transition) -> tuple[str, float | None]:
    """How main's next try after a recovery that succeeded ended: "succeeded" or "failed" (the next recovery
    began, or the recover node gave up), with when; "" if the run ended first."""
    if tried.after == "FAILURE":
        return "", None
    success = next(
        (change for change in timeline.by_node[main] if change.seq > tried.seq and change.after == "SUCCESS"),
        None,
    )
    again = timeline.first_after(timeline.children[node][1], tried.seq)
    gave_up = next(
        (change for change in timeline.by_node[node] if change.seq > tried.seq and change.after in FINISHED),
        None,
    )
    ends = [change for change in (success, again, gave_up) if change is not None]
    if not ends:
        return "", None
    first = min(ends, key=lambda change: change.seq)
    if first is success:
        return "succeeded", success.t
    return ("failed", first.t) if first.after != "INVALID" else ("", None)


@dataclass(frozen=True)
class FailureStep:
    """A node that failed on its own: when, why (its feedback), where it is defined, the blackboard values it
    reads as they were then, and what it halted as it failed (a timeout's wait: what it waited for)."""

    path: str
    name: str
    type: str
    t: float
    n: int
    feedback: str
    source: str
    reads: tuple[tuple[str, Any], ...]  # (key, value); a key unset then is left out
    halted: tuple[str, ...] = ()  # "leaf name: its feedback" of each leaf below it halted as it failed
    detail: dict[str, Any] | None = None  # what the leaf said beside its feedback (`Leaf.log_detail`)


@dataclass(frozen=True)
class FailureChain:
    """A failure the tree did not get over: the run's own (`handled` "run", `by` the root) or one a node gave
    up on so the run could go on (`given up`: a recover node out of retries, a force_success over a failed
    child, a `for_each` that goes on past a failed item); `steps` are the origins of its chain in the order they failed; it ended at `t`."""

    handled: str
    by: str
    t: float
    steps: tuple[FailureStep, ...]

    @property
    def first_cause(self) -> FailureStep:
        return first_cause(self.steps)


def first_cause(steps: Sequence[FailureStep]) -> FailureStep:
    """The earliest of `steps` (in time order) that is not control flow; the earliest if all are."""
    return next((step for step in steps if step.type not in CONTROL_FLOW), steps[0])


def failure_step(timeline: Timeline, origin: Transition) -> FailureStep:
    log = timeline.log
    node = log.nodes[origin.node]
    values = log.blackboard_at(origin.n)
    reads = tuple((key, values[key]) for key in node["reads"] if key in values)
    halted = tuple(
        f"{log.nodes[leaf]['name']}: {change.feedback or 'no feedback'}"
        for leaf in timeline.descendants(origin.node)
        if not timeline.children[leaf]
        for change in timeline.by_node[leaf]
        if change.n == origin.n and change.before == "RUNNING" and change.after == "INVALID"
    )
    return FailureStep(
        node["path"],
        node["name"],
        node["type"],
        origin.t,
        origin.n,
        origin.feedback,
        node["source"],
        reads,
        halted,
        origin.detail,
    )


def failure_chains(log: TickLog, timeline: Timeline | None = None) -> list[FailureChain]:
    """The run's failure (if it failed) and every failure a node gave up on, in the order they ended. A give-up
    inside another whose chain holds all of its origins (a recover node out of retries inside a force_success)
    is told once, by the outer one."""
    timeline = timeline or Timeline(log)
    ends = []
    root_failure = timeline.final_failure(0)
    if log.end and log.end["outcome"] == "failure" and root_failure is not None:
        ends.append(("run", 0, root_failure))
    for node in log.nodes:
        if node["type"] == "recover":
            ends += [
                ("given up", node["id"], change)
                for change in timeline.by_node[node["id"]]
                if change.after == "FAILURE"
            ]
        elif node["type"] == "force_success" or (
            node["type"] == "for_each" and node["params"].get("on_failure") == "continue"
        ):
            ends += [
                ("given up", node["id"], change)
                for child in timeline.children[node["id"]]
                for change in timeline.by_node[child]
                if change.after == "FAILURE"
            ]
    origins = {(by, end.seq): {origin.seq for origin in timeline.origins(end)} for _, by, end in ends}
    chains = []
    for handled, by, end in sorted(ends, key=lambda item: item[2].seq):
        mine = origins[(by, end.seq)]
        if any(
            other != by and _contains(log, other, by) and mine <= theirs
            for (other, _), theirs in origins.items()
        ):
            continue
        steps = tuple(failure_step(timeline, origin) for origin in timeline.origins(end))
        chains.append(FailureChain(handled, log.nodes[by]["path"], end.t, steps))
    return chains


def _contains(log: TickLog, ancestor: int, node: int) -> bool:
    parent = log.nodes[node]["parent"]
    while parent is not None:
        if parent == ancestor:
            return True
        parent = log.nodes[parent]["parent"]
    return False
