"""The power rule of `pegbt bench sim2real-outcomes`: how many real transfers a fit cell needs before the
diagnosis's gate (`pegbt.sim2real.outcomes.gate`) sees what a concealed world changes.

The gate tests a fit cell's placed row among the testable placed rows (Benjamini–Hochberg), and when none
rejects, the phase rows among the testable phase rows (their own Benjamini–Hochberg); a row is testable
when its least attainable p-value is at most 5 % (`least_p`, Tarone's rule). So a change is sized at the
level Benjamini–Hochberg gives one true row among its family's m testable rows, α/m, Bonferroni's bound on
it: conservative (BH may reject it at up to α·k/m when k rows reject), never generous. Which rows are
testable at a size is read as the gate counts them, by `least_p` on the pilot's own shares scaled to that
size. The gate opens on either family, so an effect is detectable at the fewest transfers at which any one
of its changes is seen with probability `POWER` at its row's level.

`POWER` is the naming rate the goal asks for, and the goal reads it over 5 seeds: a family detected with
probability 0.9 in each meets 5 of 5 only 0.9⁵ ≈ 59 % of the time, and the fit's own tests (χ², the
held-out gain, the replication) come after the gate. So "naming rate ≥ 0.9 over 5 seeds" is a target the
design meets on average, not on every run of five.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from scipy import stats

from pegbt.sim2real.outcomes.intervals import least_p, rate_interval

ALPHA = 0.05  # the gate's false discovery rate, and the level at which a row counts as testable
POWER = 0.9  # the naming rate the goal asks for: a difference seen this often is detectable
# the most real transfers `row_testable_from` tries: a row testable at no size below is never
LARGEST = 1 << 24


@dataclass(frozen=True)
class Change:
    """What a concealed world changes in one row of a fit cell: its share of transfers placed (`placed`)
    or failed first in one phase, the two worlds' mean `share`, the concealed less the default, and the
    share of paired transfers (same seed in both worlds) in the row in one world only."""

    placed: bool
    share: float
    change: float
    discordant: float

    @property
    def concealed(self) -> float:
        return min(1.0, max(0.0, self.share + self.change / 2))

    @property
    def default(self) -> float:
        return min(1.0, max(0.0, self.share - self.change / 2))


def detectable_difference(
    share: float, real: int, simulated: int, power: float = POWER, level: float = ALPHA
) -> float:
    """The smallest difference between a real and a simulated share (of transfers placed, or failed in
    one phase) that a two-sided test at `level` sees with probability `power`, with `real` and `simulated`
    transfers around a common `share` (normal approximation)."""
    z = float(stats.norm.ppf(1 - level / 2) + stats.norm.ppf(power))
    return z * math.sqrt(max(share * (1 - share), 1 / (real + simulated)) * (1 / real + 1 / simulated))


def row_testable(change: Change, real: int, simulated: int) -> bool:
    """Whether the gate counts this row at `real` real transfers against `simulated` simulated ones: the
    least p-value of the counts the two worlds' shares give there is at most `ALPHA` (`least_p`)."""
    counts = (round(change.concealed * real), real), (round(change.default * simulated), simulated)
    return least_p(*counts) <= ALPHA


def row_testable_from(change: Change, real: int, simulated: int) -> int | None:
    """The fewest real transfers at which the row is `testable`, the simulated side growing with them in
    the ratio `real`:`simulated`; None if it is at no size (every transfer, or none, in it on both sides)."""
    return _fewest(lambda n: row_testable(change, n, _grown(n, real, simulated)))


def transfers_to_resolve(
    difference: float, share: float, real: int, simulated: int, level: float = ALPHA
) -> int:
    """The fewest real transfers n at which `detectable_difference` at `level` is at most `difference`
    against n·`simulated`/`real` simulated transfers (rounded up); `difference` must be above 0."""
    found = _fewest(
        lambda n: detectable_difference(share, n, _grown(n, real, simulated), level=level) <= difference,
        limit=None,
    )
    assert found is not None  # the detectable difference shrinks to 0 as n grows
    return found


def levels(changes: Sequence[Change], real: int, simulated: int) -> list[float | None]:
    """Each row's level at `real` real transfers against `simulated` simulated: `ALPHA` over the testable
    rows of its family (placed rows, or phase rows), or None where the row is not testable."""
    counted = [row_testable(c, real, simulated) for c in changes]
    families = {
        placed: sum(k for c, k in zip(changes, counted) if c.placed == placed) for placed in (True, False)
    }
    return [ALPHA / families[c.placed] if k else None for c, k in zip(changes, counted)]


def detectability(changes: Sequence[Change], real: int, simulated: int) -> float:
    """The largest of a world's `changes` over the smallest difference `real` real transfers against
    `simulated` simulated ones resolve at its row's level (`levels`): 1 or more, the world shows in its fit
    cells; below 1 the gate does not see it nine times in ten (an untestable row counts 0)."""
    ratios = (
        abs(c.change) / detectable_difference(c.share, real, simulated, level=level)
        for c, level in zip(changes, levels(changes, real, simulated))
        if level is not None
    )
    return max(ratios, default=0.0)


def detectable_at(changes: Sequence[Change], real: int, simulated: int) -> int | None:
    """The fewest real transfers per fit cell at which any one of a world's `changes` is seen with
    probability `POWER` at its row's level (`levels` at that size), the simulated side growing in the ratio
    `real`:`simulated` (a diagnosis of a larger campaign locates the default world on as many more). None
    if the world changes no testable row at any size.

    A row's family counts more testable rows as the size grows, so its level falls: the size is the first,
    in each stretch of sizes over which the family's count is constant, that resolves the change at that
    stretch's level."""
    starts = [row_testable_from(c, real, simulated) for c in changes]
    sizes = []
    for c, start in zip(changes, starts):
        if not c.change or start is None:
            continue
        family = [s for s, d in zip(starts, changes) if s is not None and d.placed == c.placed]
        steps = sorted(set(family))
        for j, step in enumerate(steps):
            if step < start:
                continue
            counted = sum(s <= step for s in family)
            n = max(step, transfers_to_resolve(abs(c.change), c.share, real, simulated, ALPHA / counted))
            if j + 1 == len(steps) or n < steps[j + 1]:
                sizes.append(n)
                break
    return min(sizes, default=None)


def surely_beyond(changes: Sequence[Change], read_from: int, cap: int, real: int, simulated: int) -> bool:
    """Whether, read from `read_from` paired transfers, a world needs more than `cap` real transfers even
    at the far end of each change's 95 % interval: then it is too large with 95 % confidence (each change's
    interval alone) and reading it further cannot bring it under `cap`.

    The change is paired (the two worlds share their seeds): of the d pairs that differ in the row, b are
    in it in the concealed world only, so the change is (d/n)·(2·b/d − 1). Its interval is the farthest
    corner of Wilson's 97.5 % intervals for d/n and b/d, together at least 95 % (Bonferroni). The unpaired
    interval ignores that most pairs agree: at 1,152, grasp capture's 54 → 52 grasp failures would reach a
    change of 1.9 points, which about 4,500 real transfers resolve, and the pilot would read it to the cap.

    A row no transfer of either world is in (or every one is) stays as read: its interval, about 5/n, says
    only how many were read, and `detectable_difference`'s normal approximation is far too generous for
    shares of a few in ten thousand (0.1 % against none, 6,400 real against 2,560 simulated: Fisher's test
    needs eleven real failures beside none, not the six expected)."""
    widest = [
        Change(c.placed, c.share, _far_end(c, read_from) if 0 < c.share < 1 else c.change, c.discordant)
        for c in changes
    ]
    needed = detectable_at(widest, real, simulated)
    return needed is not None and needed > cap


def _far_end(change: Change, n: int) -> float:
    """The end of the change's 95 % interval farthest from no change, read from `n` paired transfers."""
    apart = round(change.discordant * n)
    ahead = round((change.discordant + change.change) / 2 * n)  # pairs in the row in the concealed world only
    _, most = rate_interval(apart, n, level=0.975, method="wilson")
    low, high = rate_interval(ahead, apart, level=0.975, method="wilson")
    far = max(2 * high - 1, 1 - 2 * low)
    return most * far if 2 * high - 1 >= 1 - 2 * low else -most * far


def _grown(n: int, real: int, simulated: int) -> int:
    """The simulated transfers beside `n` real ones, grown in the ratio `real`:`simulated`."""
    return math.ceil(n * simulated / real)


def _fewest(holds: Callable[[int], bool], limit: int | None = LARGEST) -> int | None:
    """The fewest n ≥ 1 for which `holds(n)`, a condition that once true stays true; None if it does not
    hold at `limit` (None: no limit, for a condition sure to hold at some n)."""
    if limit is not None and not holds(limit):
        return None
    high = 1
    while not holds(high):
        high *= 2
    low = high // 2  # 0, or a size that does not hold
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (low, middle) if holds(middle) else (middle, high)
    return high
