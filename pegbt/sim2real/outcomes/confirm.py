"""Confirm a fitted world with whole trials: `pegbt eval --world-effects` campaigns of the cells, judged by
the simulator's ground truth, beside the phase simulator's prediction (which leaves out what a whole trial
adds: perception on captures, the arms' turns, the way back, the trees' regrasps). Real cells counted as the
paper counted them are confirmed under its protocol (`--protocol paper`), as the phase simulator fits them."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from pegbt.behaviours.resources.trial import busy_seconds
from pegbt.evaluation.campaign import Cell as Campaign
from pegbt.evaluation.campaign import run_trials, trial_specs
from pegbt.evaluation.summary import summarise
from pegbt.evaluation.trial import TrialRecord
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import retried
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.goals import TIMED_CONDITIONS, Trials
from pegbt.sim2real.outcomes.paperpairs import partners_skipped

CONFIRM_SEED = 7000  # whole-trial seeds, apart from the phase simulator's


def ways_back_skipped(transfers: Sequence[Mapping[str, Any]], variant: str) -> set[int]:
    """The transfers (their `index`) of a `variant` trial the paper's robot would not have attempted: their
    pick peg no longer held a block, an earlier transfer of the trial having lost it (`FLSPegTransfer_single.py`,
    BerkeleyAutomation/FLSpegtransferHO, skips an order whose block it does not find), and in bilateral the
    other transfer of such a one's action pair (`paperpairs`). A peg no earlier transfer touched holds its
    starting block; a transfer that placed its block found it."""
    holds: dict[int, bool] = {}
    skipped = set()
    for transfer in sorted(transfers, key=lambda t: int(t["index"])):
        if not (holds.get(int(transfer["pick"]), True) or transfer["succeeded"]):
            skipped.add(int(transfer["index"]))
            continue
        holds[int(transfer["pick"])] = False
        holds[int(transfer["place"])] = bool(transfer["succeeded"])
    return skipped | partners_skipped(variant, transfers, skipped)


def _paper_counted(
    records: Sequence[TrialRecord], variant: str
) -> tuple[list[list[Mapping[str, Any]]], list[Mapping[str, Any]]]:
    """Of `records` (errored trials aside), per trial the transfers the paper's robot would have attempted,
    and all those it would not have (`ways_back_skipped`)."""
    attempted: list[list[Mapping[str, Any]]] = []
    unattempted: list[Mapping[str, Any]] = []
    for record in records:
        if record.outcome == "error":
            continue
        skipped = ways_back_skipped(record.transfers, variant)
        attempted.append([t for t in record.transfers if int(t["index"]) not in skipped])
        unattempted += [t for t in record.transfers if int(t["index"]) in skipped]
    return attempted, unattempted


def first_tries(records: Sequence[TrialRecord]) -> tuple[int, float | None]:
    """The transfers placed without a recovery inside them (`retried`, from each trial's tick log) and
    their mean time as `pegbt eval` pools it."""
    return pooled(_first_tries(r) for r in records if r.outcome != "error" and r.log)


def _first_tries(record: TrialRecord) -> list[Mapping[str, Any]]:
    """The transfers of `record` with no recovery inside them, by its tick log."""
    again = retried(read_tick_log(Path(str(record.log))))
    return [t for t in record.transfers if int(t["index"]) not in again]


def pooled(trials: Iterable[Sequence[Mapping[str, Any]]]) -> tuple[int, float | None]:
    """Of each trial's `transfers`, those placed, and their mean time as `pegbt eval` pools it: a trial's
    time transferring (two at once counted once, `busy_seconds`) over transfers placed."""
    busy, placed = 0.0, 0
    for transfers in trials:
        intervals = [
            (t["started"], t["started"] + t["seconds"])
            for t in transfers
            if t["succeeded"] and t["seconds"] is not None
        ]
        busy, placed = busy + busy_seconds(intervals), placed + len(intervals)
    return placed, (busy / placed if placed else None)


def confirm(
    world_file: Path,
    cells: Sequence[Cell],
    trials: int,
    out: Path,
    workers: int,
    until_lost: bool = False,
    protocol: str = "pegbt",
) -> dict[tuple[str, str], Trials]:
    """Per cell, `trials` whole trials in the world of `world_file` under `protocol` (`pegbt run
    --protocol`): transfers attempted and placed (with `until_lost`, a way back whose block was lost is
    skipped, not attempted, as the real cells count), their mean time, and trials that errored."""
    figures = {}
    for cell in cells:
        campaign = Campaign(
            cell.variant,
            cell.condition,
            trials,
            CONFIRM_SEED,
            world_effects=world_file.resolve(),
            protocol=protocol,
        )
        timed = cell.condition in TIMED_CONDITIONS  # its tick logs are kept and read for the first tries
        specs = trial_specs(campaign, out / f"{cell.variant}-{cell.condition}", keep_logs=timed)
        records = run_trials(specs, workers)
        summary = summarise(campaign, records, workers)
        attempted, unattempted = _paper_counted(records, cell.variant) if until_lost else ([], [])
        skipped = len(unattempted)
        tries, first_s = first_tries(records) if timed else (0, None)
        figures[cell.key] = Trials(
            attempted=summary["transfers_attempted"] - skipped,
            succeeded=summary["transfers_succeeded"] - sum(bool(t["succeeded"]) for t in unattempted),
            mean_transfer_s=pooled(attempted)[1] if until_lost else summary["mean_transfer_time_s"],
            trials=trials,
            errors=summary["errors"],
            skipped=skipped,
            first_tries=tries,
            first_try_mean_transfer_s=first_s,
        )
    return figures
