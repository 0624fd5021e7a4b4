"""The judge's view of a simulated trial: block states and the simulator's log, on the `sim/truth` query.

A trial is judged by what really happened, not by what the executive believes happened. The simulator
knows: its world decides every grasp, placement and drop from geometry, and its log holds each of
those events and each injected fault with its simulated time. `sim/truth` hands that knowledge out:
the block states now and the log entries from an index on, so a harness polling during a trial asks
only for what is new (`Truth.next`).

Simulator only, and for evaluation only (the harness that scores a trial, tests). A real robot has no
such oracle, so behaviours must never use it: they know the world through the camera and the arms.
This module holds both ends of the query: `ask_truth` for the judge, `truth_answer` for the simulator.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from pegbt.transport.keys import SimKeys
from pegbt.transport.link import Link


@dataclass(frozen=True)
class Truth:
    """What the simulator knows at simulated `time` (s since it started).

    `blocks`: per block `{block, state (on_peg, held, on_board, lost), peg, holders, pose}` with the pose
    a 4×4 in the board frame. `log`: the simulator's log entries from the requested index on, as on
    `sim/events` (world events grasp, grasp_miss, release, slip, lift, place, drop, collision; injected
    faults; refusals). `next`: the index to ask from next time for only newer entries.
    """

    time: float
    blocks: list[dict[str, Any]]
    log: list[dict[str, Any]]
    next: int

    def events(self, *kinds: str) -> list[dict[str, Any]]:
        """Log entries of the given kinds, in order."""
        return [entry for entry in self.log if entry["kind"] in kinds]


def ask_truth(link: Link, since: int = 0, timeout: float = 5.0) -> Truth:
    """Ask the simulator on `link` for its ground truth, with log entries from index `since` on."""
    answer = link.query(SimKeys(link.namespace).truth, {"since": since}, timeout)
    return Truth(answer["time"], answer["blocks"], answer["log"], answer["next"])


def requested_since(request: bytes | None) -> int:
    """The log index a `sim/truth` request asks from (0 without a request); ValueError if it is malformed."""
    try:
        since = int(json.loads(request).get("since", 0)) if request is not None else 0
    except (ValueError, TypeError, AttributeError) as error:
        raise ValueError(str(error)) from None
    if since < 0:
        raise ValueError(f"since must be >= 0, got {since}")
    return since


def truth_answer(time: float, blocks: list[dict[str, Any]], log_lines: list[str], since: int) -> str:
    """The JSON answer `ask_truth` reads: `log_lines` are the log's entries, each already one line of JSON."""
    log = ",".join(log_lines[since:])
    return f'{{"time": {time!r}, "blocks": {json.dumps(blocks)}, "log": [{log}], "next": {len(log_lines)}}}'
