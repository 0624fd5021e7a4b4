"""Whether whole trials in a fitted world meet the issue's goals, cell by cell, as verdicts a reader can
check from the counts beside them.

A cell the real robot placed in full must keep `KEEPS` (98 %): judged by the point rate (at most 2 of 120
transfers failed), with the Wilson 95 % interval the phase simulator's bound uses beside it; 98 % is below
it beyond chance only when the interval's top is under 98 %, and shown beyond chance only when its bottom
reaches 98 %, which with none failed takes `transfers_to_keep()` (189) transfers, more than ten trials
hold. Any other cell's rate must lie in the real count's 95 % interval (the test a held-out prediction is
held to), and an uncalibrated cell's mean transfer time must be within `TIME_TOLERANCE` of the real one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.intervals import disagreement_p, rate_interval
from pegbt.sim2real.outcomes.predict import KEEPS, transfers_to_keep

TIME_TOLERANCE = 0.2  # a simulated mean transfer time this close to the real one (relative) agrees with it
TIMED_CONDITIONS = ("uncalibrated",)  # the paper's own rest-to-rest cubics; calibrated and optimised
# plans are pegbt's planner's, faster by design, so their times are shown, not judged


def time_agrees(real: float | None, simulated: float | None) -> bool | None:
    """Whether a simulated mean transfer time (of the transfers placed) is within `TIME_TOLERANCE` of the
    real one; None where either is unknown (no real time, or nothing placed)."""
    if real is None or simulated is None:
        return None
    return abs(simulated - real) <= TIME_TOLERANCE * real


@dataclass(frozen=True)
class Trials:
    """Whole trials of one cell in one world: transfers attempted and placed, counted as the real cells
    count them, the ways back that counting skipped (their block lost on the way out), the placed
    transfers' mean time (s), and how many trials ran and errored (an errored trial counts no transfer);
    where the time is judged, the transfers placed at their first try and their mean time, the paper's
    robot having never tried twice."""

    attempted: int
    succeeded: int
    mean_transfer_s: float | None
    trials: int
    errors: int
    skipped: int = 0
    first_tries: int = 0  # transfers placed without a recovery, timed only where the time is judged
    first_try_mean_transfer_s: float | None = None

    @property
    def rate(self) -> float | None:
        return self.succeeded / self.attempted if self.attempted else None


def placed_in_full(cell: Cell) -> bool:
    return bool(cell.attempted) and cell.succeeded == cell.attempted


def judge(real: Cell, trials: Trials) -> dict[str, Any]:
    """The goals of `real`'s cell on `trials`: the rate's goal and verdict, the time's where it is judged,
    and `holds`, both together (a time that cannot be judged, nothing being placed, does not fail it)."""
    low, high = rate_interval(trials.succeeded, trials.attempted, method="wilson")
    rate = trials.rate
    verdict: dict[str, Any] = {"rate": rate, "interval": [low, high]}
    if placed_in_full(real):
        rate_holds = rate is not None and rate >= KEEPS
        verdict |= {
            "goal": f"placed >= {100 * KEEPS:.0f} %",
            "shown": low >= KEEPS,
            "below_beyond_chance": high < KEEPS,
        }
    else:
        real_low, real_high = rate_interval(real.succeeded, real.attempted)
        rate_holds = rate is not None and real_low <= rate <= real_high
        verdict |= {
            "goal": "rate in the real 95 % interval",
            "real_interval": [real_low, real_high],
            "p_value": disagreement_p((real.succeeded, real.attempted), (trials.succeeded, trials.attempted)),
        }
    timed = real.condition in TIMED_CONDITIONS
    time_holds = time_agrees(real.mean_transfer_s, trials.mean_transfer_s) if timed else None
    ratio = (
        trials.mean_transfer_s / real.mean_transfer_s
        if trials.mean_transfer_s is not None and real.mean_transfer_s
        else None
    )
    first = trials.first_try_mean_transfer_s
    return verdict | {
        "first_tries": trials.first_tries,
        "first_try_mean_transfer_s": first,
        "first_try_ratio": first / real.mean_transfer_s
        if first is not None and real.mean_transfer_s
        else None,
        "rate_holds": rate_holds,
        "real_mean_transfer_s": real.mean_transfer_s,
        "mean_transfer_s_ratio": ratio,
        "time_judged": timed,
        "time_holds": time_holds,
        "holds": rate_holds and time_holds is not False,
    }


def percent(rate: float | None) -> str:
    """A rate as a percentage to one decimal, a dash where there is none."""
    return "–" if rate is None else f"{100 * rate:.1f} %"


def verdict_text(verdict: dict[str, Any]) -> str:
    """One cell's verdict in words: the goal, whether it holds, and what the interval says of it."""
    if "shown" in verdict:
        if verdict["rate_holds"]:
            said = "holds" + (
                ", shown beyond chance"
                if verdict["shown"]
                else f", not shown beyond chance ({transfers_to_keep()} needed)"
            )
        else:
            said = "**fails**" + (
                ", below 98 % beyond chance" if verdict["below_beyond_chance"] else " (within chance)"
            )
    else:
        low, high = verdict["real_interval"]
        said = (
            f"rate {'in' if verdict['rate_holds'] else '**not in**'} real {percent(low)}–{percent(high)} "
            f"(Fisher p = {verdict['p_value']:.2g})"
        )
    if verdict["time_judged"]:
        ratio = verdict["mean_transfer_s_ratio"]
        said += (
            "; time not judged (nothing placed)"
            if ratio is None
            else f"; time {100 * (ratio - 1):+.0f} %, {'within' if verdict['time_holds'] else '**not within**'} 20 %"
        )
        first = verdict["first_try_ratio"]
        if first is not None:
            said += f" (its {verdict['first_tries']} first tries {100 * (first - 1):+.0f} %)"
    return said
