"""Confirm a fitted world with whole trials: `pegbt eval --world-effects` campaigns of the cells, judged by
the simulator's ground truth, beside the phase simulator's prediction (which leaves out what a whole trial
adds: perception on captures, the arms' turns, the way back)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pegbt.evaluation.campaign import Cell as Campaign
from pegbt.evaluation.campaign import run_trials, trial_specs
from pegbt.evaluation.summary import summarise
from pegbt.sim2real.outcomes.cells import Cell

CONFIRM_SEED = 7000  # whole-trial seeds, apart from the phase simulator's


def confirm(
    world_file: Path, cells: Sequence[Cell], trials: int, out: Path, workers: int
) -> dict[tuple[str, str], dict[str, Any]]:
    """Per cell, `trials` whole trials in the world of `world_file`: transfers attempted and placed, their
    mean time, and trials that errored."""
    figures = {}
    for cell in cells:
        campaign = Campaign(
            cell.variant, cell.condition, trials, CONFIRM_SEED, world_effects=world_file.resolve()
        )
        records = run_trials(trial_specs(campaign, out / f"{cell.variant}-{cell.condition}"), workers)
        summary = summarise(campaign, records, workers)
        figures[cell.key] = {
            "attempted": summary["transfers_attempted"],
            "succeeded": summary["transfers_succeeded"],
            "mean_transfer_s": summary["mean_transfer_time_s"],
            "trials": trials,
            "errors": summary["errors"],
        }
    return figures
