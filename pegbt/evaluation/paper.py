"""The reference paper's figures (Hwang et al., T-ASE 2022, 10 trials × 12 transfers per cell) and our goals.

From `../shared/reference/peg-transfer-geometry.md`; shown beside every measured cell.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PaperCell:
    """One cell of the paper's Tables II–IV: mean transfer time (s) and success rate (0–1)."""

    mean_transfer_time_s: float
    success_rate: float
    trial_time_s: float | None = None  # trial completion time, reported for calibrated + optimised only
    trial_time_sd_s: float | None = None


PAPER: dict[tuple[str, str], PaperCell] = {
    ("unilateral", "uncalibrated"): PaperCell(5.6, 0.347),
    ("unilateral", "calibrated"): PaperCell(5.7, 1.0),
    ("unilateral", "optimized"): PaperCell(5.2, 1.0, 62.6, 0.7),
    ("bilateral", "uncalibrated"): PaperCell(3.6, 0.544),
    ("bilateral", "calibrated"): PaperCell(3.5, 1.0),
    ("bilateral", "optimized"): PaperCell(3.0, 1.0, 40.4, 0.5),
    ("handover", "uncalibrated"): PaperCell(6.3, 0.177),
    ("handover", "calibrated"): PaperCell(6.1, 1.0),
    ("handover", "optimized"): PaperCell(6.0, 1.0, 72.5, 1.3),
}

# The paper's surgeon (the human column of its Tables II-IV): mean transfer time (s) and success rate.
SURGEON: dict[str, PaperCell] = {
    "unilateral": PaperCell(4.7, 1.0),
    "bilateral": PaperCell(4.8, 0.975),
    "handover": PaperCell(7.9, 1.0),
}
PAPER_COLLISIONS = 0  # "the robot never collided" (the paper, calibrated and optimised trials)

# The goals pegbt is held to: success over calibrated conditions, mean transfer time below the paper's
# optimised figure, no arm-arm collision, a 12-transfer trial within this much wall time.
GOAL_SUCCESS_RATE = 0.99
GOAL_WALL_S = 10.0


def goal_mean_transfer_s(variant: str) -> float:
    """The paper's calibrated + optimised mean transfer time: the time to beat."""
    return PAPER[(variant, "optimized")].mean_transfer_time_s
