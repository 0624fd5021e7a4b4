"""The order of a variant's transfers and the arm that carries each, as the trees loop over them.

The phase simulator simulates one transfer of a trial at a time: which arm picks which block, which arm
receives it at a handover, how many transfers run at once and where a way back finds the blocks are
facts of the trial's order (`trees/shared/orders.yaml`), kept apart from how a transfer is played.
"""

from __future__ import annotations

from pegbt.frames import yaw_of, yaw_pose
from pegbt.sim.world import World
from pegbt.workcell import transfer_list


def transfers(variant: str) -> tuple[tuple[str, int, int], ...]:
    """(arm, start peg, goal peg) of each of `variant`'s transfers, out and back, from the lists the trees
    loop over (`trees/shared/orders.yaml`): the handover's giver is PSM2 for the first six, PSM1 after;
    bilateral's arms take their halves in turn."""
    reference = transfer_list("reference")
    if variant == "unilateral":
        return tuple(("PSM1", *pegs) for pegs in reference)
    if variant == "handover":
        half = len(reference) // 2
        return tuple(("PSM2" if i < half else "PSM1", *pegs) for i, pegs in enumerate(reference))
    psm2, psm1 = transfer_list("bilateral_PSM2"), transfer_list("bilateral_PSM1")
    half = len(psm2) // 2
    return tuple(
        [("PSM2", *p) for p in psm2[:half]]
        + [("PSM1", *p) for p in psm1[:half]]
        + [("PSM2", *p) for p in psm2[half:]]
        + [("PSM1", *p) for p in psm1[half:]]
    )


def arms_at_once(variant: str) -> int:
    """How many of `variant`'s transfers run at once: bilateral's two arms each carry a block together
    (the paper's `FLSPegTransfer_dual.py` moves an action pair, one block per arm, in parallel threads,
    `motion/dvrkPegTransferMotionDualArm.py`; pegbt's bilateral trees run each arm's list in parallel), so a
    trial's time per transfer is half of one arm's; the others move one block at a time."""
    return 2 if variant == "bilateral" else 1


RECEIVER = {"PSM1": "PSM2", "PSM2": "PSM1"}  # a handover's receiver, by its giver


def moved_out(world: World, order: tuple[tuple[str, int, int], ...]) -> None:
    """Seat every block on the peg its outward transfer places it on, as a trial's way back finds them
    (each at its layout's yaw: where a placement leaves it turned is the lowering's business)."""
    goal_of = {start: goal for _, start, goal in order[: len(order) // 2]}
    for block in world.blocks:
        assert block.peg is not None  # a new world's blocks all rest on their pegs
        x, y = world.cell.pegs.positions[goal_of[block.peg]]
        block.pose = yaw_pose([x, y, world.cell.board.surface_z], yaw_of(block.pose))
        block.peg = goal_of[block.peg]
