"""`pegbt bench sim2real-outcomes`'s bookkeeping: what a family's concealed world can show at the real
side's size, and how a diagnosis is scored against the concealed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pegbt.bench import sim2real_outcomes as bench
from pegbt.sim2real.outcomes.diagnose import Diagnosis, Settings
from pegbt.sim2real.outcomes.fit import Candidate, Profile, Verdict
from tests.outcomes_helpers import fake_mapper


def test_a_world_that_moves_a_fit_cell_is_detectable_and_one_that_does_not_is_not() -> None:
    """On the stand-in simulator a bending peg lifts more blocks and chamfers change nothing; the null has
    nothing to detect, and a world that changes nothing is detectable at no campaign size."""
    settings = Settings(fit="unilateral", transfers=12, located=200)
    worlds = {family: bench.FAMILIES[family] for family in ("peg_compliance", "chamfer_capture", "null")}
    changes = bench.shifts(fake_mapper, worlds, settings)
    assert set(changes) == {"peg_compliance", "chamfer_capture"}
    assert bench.detectability(changes["peg_compliance"], 120, 200) >= 1
    assert bench.detectability(changes["chamfer_capture"], 120, 200) == 0
    assert bench.detectable_at(changes["peg_compliance"], 120, 200) <= 120  # type: ignore[operator]
    assert bench.detectable_at(changes["chamfer_capture"], 120, 200) is None


def _diagnosis(kind: str, parameter: str, values: tuple[float, ...], totals: list[float]) -> Diagnosis:
    fitted = Profile(Candidate(kind, parameter, values), values, [], np.array(totals)[:, None])
    verdict = Verdict((fitted,), (), (fitted,), np.zeros(1), ())
    return Diagnosis(None, Settings(), (), (), {}, [], verdict, {})  # type: ignore[arg-type]


def test_the_parameter_error_is_the_estimates_and_resolution_follows_the_goal() -> None:
    """The profile peaks between the grid's 1.5 and 2.25 mm: the error is the estimate's, not the best
    grid value's; and the goal's ± 30 % (or a ± 50 % interval holding the truth) decides `resolved`."""
    grid = (0.00075, 0.0015, 0.00225, 0.003)
    dense = np.linspace(grid[0], grid[-1], 301)
    d = _diagnosis("peg_compliance", "deflection", grid, [-9.0, -1.0, -1.0, -9.0])
    d.verdict.named[0].dense = (dense, -(((dense - 0.0019) / 0.0002) ** 2) / 2)
    hidden = {"peg_compliance": {"deflection": 0.0015}}
    figures = bench.score(d, hidden)
    assert figures["named"] == 1 and figures["false"] == 0
    assert figures["error"] == pytest.approx(0.0004 / 0.0015, abs=0.01)
    assert figures["resolved"] == 1
    assert bench.score(d, {"peg_compliance": {"deflection": 0.0011}})["resolved"] == 0
    assert math.isnan(bench.score(d, {})["resolved"]) and bench.score(d, {})["false"] == 1


def test_an_unnamed_concealed_effect_is_not_resolved() -> None:
    d = _diagnosis("registration_offset", "x", (-0.005, -0.0025, 0.0025, 0.005), [-9.0, -1.0, 0.0, -9.0])
    hidden = {"peg_compliance": {"deflection": 0.0015}}
    assert bench.score(d, hidden)["resolved"] == 0 and bench.score(d, hidden)["false"] == 1
