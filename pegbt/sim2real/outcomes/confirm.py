"""Confirm a fitted world with whole trials: `pegbt eval --world-effects` campaigns of the cells, judged by
the simulator's ground truth, beside the phase simulator's prediction (which leaves out what a whole trial
adds: perception on captures, the arms' turns, the way back, the trees' regrasps)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from pegbt.evaluation.campaign import Cell as Campaign
from pegbt.evaluation.campaign import run_trials, trial_specs
from pegbt.evaluation.summary import summarise
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.goals import Trials

CONFIRM_SEED = 7000  # whole-trial seeds, apart from the phase simulator's


def ways_back_skipped(transfers: Sequence[Mapping[str, Any]]) -> int:
    """How many of a trial's transfers the paper's robot would not have attempted: their pick peg no
    longer held a block, an earlier transfer of the trial having lost it (`FLSPegTransfer_single.py`,
    BerkeleyAutomation/FLSpegtransferHO, skips an order whose block it does not find). A peg no earlier
    transfer touched holds its starting block; a transfer that placed its block found it."""
    holds: dict[int, bool] = {}
    skipped = 0
    for transfer in sorted(transfers, key=lambda t: int(t["index"])):
        if not (holds.get(int(transfer["pick"]), True) or transfer["succeeded"]):
            skipped += 1
            continue
        holds[int(transfer["pick"])] = False
        holds[int(transfer["place"])] = bool(transfer["succeeded"])
    return skipped


def confirm(
    world_file: Path,
    cells: Sequence[Cell],
    trials: int,
    out: Path,
    workers: int,
    until_lost: bool = False,
) -> dict[tuple[str, str], Trials]:
    """Per cell, `trials` whole trials in the world of `world_file`: transfers attempted and placed (with
    `until_lost`, a way back whose block was lost is skipped, not attempted, as the real cells count),
    their mean time, and trials that errored."""
    figures = {}
    for cell in cells:
        campaign = Campaign(
            cell.variant, cell.condition, trials, CONFIRM_SEED, world_effects=world_file.resolve()
        )
        records = run_trials(trial_specs(campaign, out / f"{cell.variant}-{cell.condition}"), workers)
        summary = summarise(campaign, records, workers)
        skipped = (
            sum(ways_back_skipped(r.transfers) for r in records if r.outcome != "error") if until_lost else 0
        )
        figures[cell.key] = Trials(
            attempted=summary["transfers_attempted"] - skipped,
            succeeded=summary["transfers_succeeded"],
            mean_transfer_s=summary["mean_transfer_time_s"],
            trials=trials,
            errors=summary["errors"],
            skipped=skipped,
        )
    return figures
