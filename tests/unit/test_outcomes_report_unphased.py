"""A cell whose failures per phase cannot all be read (a tick log's failure of no known phase, or counts
that do not add up) is judged on its placed rate alone, and the report says so and why, rather than
silently comparing less than the cell gave."""

from __future__ import annotations

from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.report import report_markdown
from tests.outcomes_helpers import fake_mapper


def test_failures_of_no_known_phase_are_said_to_be_set_aside() -> None:
    cells = (
        Cell("unilateral", "uncalibrated", 40, 4, None, {"lift": 35, "unknown": 1}),
        Cell("unilateral", "calibrated", 40, 40),
        Cell("bilateral", "uncalibrated", 40, 6, None, {"lift": 30}),
        Cell("bilateral", "calibrated", 40, 40, None, {"lift": 0}),
    )
    markdown = report_markdown(
        diagnose(Outcomes(cells, "test"), Settings(transfers=12, points=2), fake_mapper)
    )
    assert (
        "unilateral uncalibrated: its failures per phase are set aside and it is compared on its placed rate "
        "alone (1 failed in `unknown`, no phase the simulator tells apart)." in markdown
    )
    assert (
        "bilateral uncalibrated: its failures per phase are set aside and it is compared on its placed "
        "rate alone (30 failures per phase for 34 failed)." in markdown
    )
    assert (
        "bilateral calibrated: its failures" not in markdown and "unilateral calibrated: its" not in markdown
    )
