"""The rest of the paper's Fig. 10 from `pegbt eval --out DIR`: per variant (columns) and condition, the
success rate with error bars, and per trial the tool-tip path, the arm-arm collisions and the completion
time as box plots, with the paper's robot figures (red diamonds, its ± where it gives one) and its
surgeon (green) beside ours where `pegbt.evaluation.paper` has them. Drawn from every clean cell's
`trials-VARIANT-CONDITION.csv` in DIR, as `transfer_times.png` is from the transfers.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pegbt.evaluation.paper import PAPER, PAPER_COLLISIONS, SURGEON
from pegbt.runconditions import CONDITIONS, VARIANTS

if TYPE_CHECKING:
    from matplotlib.axes import Axes

PLOT = "trial_figures.png"
ROWS = (
    ("success", "transfer success rate (%)"),
    ("tip_path_m", "planned tool-tip path per trial (m)"),
    ("arm_arm_collisions", "arm-arm collisions per trial"),
    ("trial_time_s", "trial completion time (s)"),
)


def trial_rows(out: Path) -> dict[tuple[str, str], list[dict[str, float]]]:
    """Per (variant, condition): each trial that ran (no error) as its figures."""
    cells: dict[tuple[str, str], list[dict[str, float]]] = {}
    for variant in VARIANTS:
        for condition in CONDITIONS:
            path = out / f"trials-{variant}-{condition}.csv"
            if not path.exists():
                continue
            with path.open(newline="", encoding="utf-8") as file:
                trials = [row for row in csv.DictReader(file) if row["outcome"] != "error"]
            cells[(variant, condition)] = [
                {
                    "success": 100.0
                    * int(row["transfers_succeeded"])
                    / max(1, int(row["transfers_attempted"])),
                    "tip_path_m": float(row["tip_path_m"]),
                    "arm_arm_collisions": float(row["arm_arm_collisions"]),
                    "trial_time_s": float(row["trial_time_s"]),
                }
                for row in trials
            ]
    return cells


def plot_trial_figures(out: Path) -> Path:
    """Draw `trial_figures.png` in `out` (see the module docstring) and return its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells = trial_rows(out)
    figure, axes = plt.subplots(len(ROWS), len(VARIANTS), figsize=(13, 12), sharey="row", squeeze=False)
    for column, variant in enumerate(VARIANTS):
        conditions = [c for c in CONDITIONS if cells.get((variant, c))]
        positions = np.arange(1, len(conditions) + 1)
        for row, (key, label) in enumerate(ROWS):
            axis = axes[row][column]
            values = [[trial[key] for trial in cells[(variant, c)]] for c in conditions]
            if key == "success":
                _success(axis, variant, conditions, values)
            elif conditions:
                axis.boxplot(values, positions=positions, widths=0.5)
                _paper_marks(axis, key, variant, conditions, positions)
            axis.set_xticks(
                list(positions) + ([len(conditions) + 1] if key == "success" else []),
                conditions + (["surgeon\n(paper)"] if key == "success" else []),
            )
            axis.grid(axis="y", alpha=0.3)
            if column == 0:
                axis.set_ylabel(label)
            if row == 0:
                axis.set_title(variant)
    handles = [
        plt.Line2D([], [], marker="D", color="tab:red", linestyle="", label="paper: robot"),
        plt.Line2D([], [], marker="o", color="tab:green", linestyle="", label="paper: surgeon"),
        plt.Line2D([], [], marker="s", color="tab:blue", linestyle="", label="ours: mean ± sd over trials"),
    ]
    figure.legend(handles=handles, loc="lower center", ncol=3)
    figure.suptitle(
        "Fig. 10 figures per variant and condition (simulator, dvrk-real physics), with the paper's"
    )
    figure.tight_layout(rect=(0, 0.03, 1, 1))
    path = out / PLOT
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


def _success(axis: Axes, variant: str, conditions: list[str], values: list[list[float]]) -> None:
    positions = np.arange(1, len(conditions) + 1)
    if conditions:
        means = [float(np.mean(v)) for v in values]
        spreads = [float(np.std(v)) for v in values]
        axis.bar(positions, means, width=0.5, color="tab:blue", alpha=0.35)
        axis.errorbar(positions, means, yerr=spreads, fmt="s", color="tab:blue", capsize=4)
        axis.scatter(
            positions,
            [100 * PAPER[(variant, c)].success_rate for c in conditions],
            marker="D",
            color="tab:red",
        )
    axis.scatter([len(conditions) + 1], [100 * SURGEON[variant].success_rate], marker="o", color="tab:green")
    axis.set_ylim(0, 105)


def _paper_marks(axis: Axes, key: str, variant: str, conditions: list[str], positions: np.ndarray) -> None:
    for position, condition in zip(positions, conditions):
        paper = PAPER[(variant, condition)]
        if key == "trial_time_s" and paper.trial_time_s is not None:
            axis.errorbar(
                [position + 0.3], [paper.trial_time_s], yerr=paper.trial_time_sd_s, fmt="D", color="tab:red"
            )
        elif key == "arm_arm_collisions" and condition == "optimized":
            axis.scatter([position + 0.3], [PAPER_COLLISIONS], marker="D", color="tab:red")
