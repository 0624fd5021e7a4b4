"""What `pegbt eval --out DIR` writes: per cell a CSV row per trial, a CSV row per transfer and the
summary as JSON; and `transfer_times.png`, box plots of transfer times like the paper's Fig. 10, drawn
from every clean cell's transfers in DIR (run the nine cells into one DIR to fill it).
"""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pegbt.errors import PegbtError
from pegbt.evaluation.campaign import Cell
from pegbt.evaluation.paper import PAPER
from pegbt.evaluation.trial import TrialRecord
from pegbt.runconditions import CONDITIONS, VARIANTS

TRIAL_COLUMNS = (
    "variant",
    "condition",
    "seed",
    "outcome",
    "transfers_attempted",
    "transfers_succeeded",
    "mean_transfer_time_s",
    "trial_time_s",
    "wall_time_s",
    "run_wall_s",
    "arm_arm_collisions",
    "other_contacts",
    "commands_clipped",
    "arm_faults",
    "tip_path_m",
    "fallbacks",
    "overruns",
    "compute_waited_s",
    "compute_s",
    "faults_injected",
    "faults_recovered",
    "why_checked",
    "why_agreed",
    "log",
    "error",
)
TRANSFER_COLUMNS = (
    "variant",
    "condition",
    "seed",
    "index",
    "arms",
    "pick",
    "place",
    "succeeded",
    "seconds",
    "started",
    "ended",
    "note",
    "cause",
    "cause_event",
)
PLOT = "transfer_times.png"


def _trial_row(record: TrialRecord) -> dict[str, Any]:
    row = {column: getattr(record, column) for column in TRIAL_COLUMNS if hasattr(record, column)}
    row.update(
        faults_injected=len(record.faults),
        faults_recovered=sum(f["recovered"] for f in record.faults),
        why_checked=len(record.why),
        why_agreed=sum(c["agrees"] for c in record.why),
    )
    return row


def write_cell(out: Path, cell: Cell, records: Sequence[TrialRecord], figures: dict[str, Any]) -> list[Path]:
    """Write `trials-CELL.csv`, `transfers-CELL.csv` and `summary-CELL.json` into `out`; returns their paths."""
    paths = [
        out / f"trials-{cell.name}.csv",
        out / f"transfers-{cell.name}.csv",
        out / f"summary-{cell.name}.json",
    ]
    try:
        out.mkdir(parents=True, exist_ok=True)
        _write_csv(paths[0], TRIAL_COLUMNS, [_trial_row(r) for r in records])
        rows = [
            {"variant": r.variant, "condition": r.condition, "seed": r.seed, **t}
            for r in records
            for t in r.transfers
        ]
        _write_csv(paths[1], TRANSFER_COLUMNS, rows)
        paths[2].write_text(json.dumps(figures, indent=1) + "\n", encoding="utf-8")
    except OSError as error:
        raise PegbtError(f"cannot write results: {error.strerror}", file=error.filename or out) from None
    return paths


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> None:
    with path.open("w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def transfer_times(out: Path) -> dict[tuple[str, str], list[float]]:
    """Successful transfers' times of every clean cell written in `out`, by (variant, condition)."""
    times: dict[tuple[str, str], list[float]] = {}
    for variant in VARIANTS:
        for condition in CONDITIONS:
            path = out / f"transfers-{variant}-{condition}.csv"
            if path.exists():
                with path.open(newline="", encoding="utf-8") as file:
                    times[(variant, condition)] = [
                        float(row["seconds"])
                        for row in csv.DictReader(file)
                        if row["succeeded"] == "True" and row["seconds"]
                    ]
    return times


def plot_transfer_times(out: Path) -> Path:
    """Box plots of transfer times per variant (one panel each) and condition, the paper's mean as a mark."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times = transfer_times(out)
    figure, axes = plt.subplots(1, len(VARIANTS), figsize=(12, 4), sharey=True)
    for axis, variant in zip(axes, VARIANTS):
        conditions = [c for c in CONDITIONS if times.get((variant, c))]
        if conditions:
            axis.boxplot([times[(variant, c)] for c in conditions], showfliers=True)
            axis.set_xticks(range(1, len(conditions) + 1), conditions)
            axis.scatter(
                range(1, len(conditions) + 1),
                [PAPER[(variant, c)].mean_transfer_time_s for c in conditions],
                marker="D",
                color="tab:red",
                zorder=3,
                label="paper's mean",
            )
            axis.legend(loc="upper right", fontsize="small")
        axis.set_title(variant)
        axis.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("transfer time (s), successful transfers")
    figure.suptitle("Transfer times per variant and condition (simulator, dvrk-real physics)")
    figure.tight_layout()
    path = out / PLOT
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
