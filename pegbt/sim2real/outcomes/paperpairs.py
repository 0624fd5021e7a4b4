"""The reference paper's bilateral action pairs, for the phase simulator's paper protocol (`registered`).

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_dual.py`: the two arms move an action pair at once
(`action_list`: one block each, PSM2's and PSM1's), and `main`'s `find_block` state looks for both blocks on
their pick pegs before the pair moves (`if pose_blk_pick1 != [] and pose_blk_pick2 != []`); otherwise "No
block to move was detected. Skip this order.": neither arm moves. So on the way back a block lost on the
way out skips its partner's transfer too, though that block lies ready on its peg. The trees' lists
`bilateral_PSM2` and `bilateral_PSM1` (`trees/shared/orders.yaml`) hold the pairs in the action list's
order, one list per arm; pegbt's trees run each arm's list on its own.
"""

from __future__ import annotations

from pegbt.sim2real.outcomes.transfer_order import arms_at_once, transfers


def action_partner(variant: str, index: int) -> int | None:
    """The other transfer of transfer `index`'s action pair (an index of `transfers(variant)`): the other
    arm's at the same place in its own list; None where one block moves at a time."""
    if arms_at_once(variant) == 1:
        return None
    order = transfers(variant)
    arm = order[index][0]
    mine = [i for i, (other, _, _) in enumerate(order) if other == arm]
    theirs = [i for i, (other, _, _) in enumerate(order) if other != arm]
    return theirs[mine.index(index)]
