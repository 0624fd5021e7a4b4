"""The report sets each cell's simulated mean transfer time beside the real table's: of the transfers
placed (a failed one ends where the failure stopped the arm, which no real table's time counts)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.goals import time_agrees
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.report import report_dict, report_markdown
from pegbt.sim2real.outcomes.simulate import SimCounts, Task

PLACED_S = {"unilateral": 5.0, "bilateral": 3.0}  # a placed transfer's seconds; a failed one takes 1 s


def _mapper(tasks: Sequence[Task]) -> list[list[TransferResult]]:
    out = []
    for worlds, variant, _condition, seed in tasks:
        placed = np.random.default_rng([seed, 5]).random() < 0.5
        result = (
            TransferResult(True, None, PLACED_S[variant]) if placed else TransferResult(False, "lift", 1.0)
        )
        out.append([result for _ in worlds])
    return out


def test_simulated_mean_transfer_time_counts_placed_transfers_only() -> None:
    counts = SimCounts()
    for result in (
        TransferResult(True, None, 6.0),
        TransferResult(False, "lift", 1.0),
        TransferResult(True, None, 4.0),
    ):
        counts.add(result)
    other = SimCounts()
    other.add(TransferResult(True, None, 8.0))
    counts.merge(other)
    assert counts.mean_transfer_s == 6.0
    assert SimCounts().mean_transfer_s is None


def test_the_report_sets_simulated_mean_transfer_times_beside_the_real_ones() -> None:
    cells = (
        Cell("unilateral", "uncalibrated", 40, 20, mean_transfer_s=5.6),
        Cell("bilateral", "uncalibrated", 40, 20, mean_transfer_s=3.6),
    )
    d = diagnose(Outcomes(cells, "test"), Settings(fit="unilateral", transfers=40, points=3), _mapper)
    by_variant = {c["variant"]: c for c in report_dict(d)["cells"]}
    assert by_variant["unilateral"]["simulated_mean_transfer_s_after"] == 5.0
    assert by_variant["unilateral"]["mean_transfer_s_within_20_percent"] is True
    assert by_variant["bilateral"]["simulated_mean_transfer_s_before"] == 1.5  # two arms carry at once
    markdown = report_markdown(d)
    assert "| 5.6 / 5.0 / 5.0 (within 20 %) |" in markdown
    assert time_agrees(3.6, 4.4) is False and time_agrees(3.6, None) is None
