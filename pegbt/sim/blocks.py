"""The state of one FLS block in the simulated world."""

from __future__ import annotations

from dataclasses import dataclass, field

from pegbt.frames import Matrix


@dataclass
class Block:
    """Pose (board frame, block frame as in `pegbt.workcell.BlockModel`) and what holds it.

    `peg` is the peg through the block's hole: the one it rests on, or the one it is still threaded on
    while being lifted. `grips` maps each arm gripping it to the block's pose in that arm's tip frame,
    in the order the grips were taken (the first holder carries the block).
    """

    index: int
    pose: Matrix
    peg: int | None
    lost: bool = False
    grips: dict[str, Matrix] = field(default_factory=dict)

    @property
    def state(self) -> str:
        """ "held", "on_peg", "on_board" or "lost" (fell off the workspace)."""
        if self.lost:
            return "lost"
        if self.grips:
            return "held"
        return "on_board" if self.peg is None else "on_peg"

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary: state, peg, holders and the 4×4 pose as nested lists."""
        return {
            "block": self.index,
            "state": self.state,
            "peg": self.peg,
            "holders": list(self.grips),
            "pose": self.pose.round(6).tolist(),
        }
