"""The judge's view of a simulated trial: block states and the simulator's log, asked of `sim/truth`.

Simulator only, and for evaluation only (the harness that scores a trial, tests). A real robot has no
such oracle, so behaviours must never use it: they know the world through the camera and the arms.
"""

from __future__ import annotations

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
