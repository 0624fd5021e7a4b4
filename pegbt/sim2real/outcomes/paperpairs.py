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

from collections.abc import Mapping, Sequence
from typing import Any

from pegbt.errors import PegbtError
from pegbt.sim2real.outcomes.transfer_order import arms_at_once
from pegbt.sim2real.outcomes.transfer_order import transfers as transfers_of


def action_partner(variant: str, index: int) -> int | None:
    """The other transfer of transfer `index`'s action pair (an index of `transfers(variant)`): the other
    arm's at the same place in its own list; None where one block moves at a time."""
    if arms_at_once(variant) == 1:
        return None
    order = transfers_of(variant)
    arm = order[index][0]
    mine = [i for i, (other, _, _) in enumerate(order) if other == arm]
    theirs = [i for i, (other, _, _) in enumerate(order) if other != arm]
    return theirs[mine.index(index)]


def partners_skipped(variant: str, transfers: Sequence[Mapping[str, Any]], skipped: set[int]) -> set[int]:
    """The transfers of a trial (`index`, `pick`, `place`) whose action partner is among `skipped`: the
    paper's robot moves both blocks of a pair or neither. A transfer is known by its pegs, which name one
    transfer of `variant`'s order; a skipped index that is not one of `transfers`, or whose pegs are not,
    is a `PegbtError` (a partner left unskipped would be counted as attempted)."""
    if arms_at_once(variant) == 1 or not skipped:
        return set()
    order = [(start, goal) for _, start, goal in transfers_of(variant)]
    pegs_of = {int(t["index"]): (int(t["pick"]), int(t["place"])) for t in transfers}
    index_of = {pegs: index for index, pegs in pegs_of.items()}
    partners = set()
    for index in sorted(skipped):
        partner = action_partner(variant, _order_index(variant, order, pegs_of, index))
        if partner is not None and order[partner] in index_of:
            partners.add(index_of[order[partner]])
    return partners - skipped


def _order_index(
    variant: str, order: list[tuple[int, int]], pegs_of: Mapping[int, tuple[int, int]], index: int
) -> int:
    """Where the trial's transfer `index` (its pegs `pegs_of[index]`) is in `variant`'s `order`."""
    if index not in pegs_of:
        raise PegbtError(
            f"skipped transfer {index} is not one of the trial's transfers ({sorted(pegs_of)})",
            field="skipped",
        )
    if pegs_of[index] not in order:
        pick, place = pegs_of[index]
        raise PegbtError(
            f"skipped transfer {index} ({pick} -> {place}) is not one of {variant}'s transfers "
            "(trees/shared/orders.yaml)",
            field="skipped",
        )
    return order.index(pegs_of[index])
