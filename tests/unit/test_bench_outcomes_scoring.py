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


def test_the_detectable_difference_shrinks_with_the_real_sample() -> None:
    """At a share of one half, 48 simulated transfers against 40 real resolve 35 points; against 120, 28."""
    assert bench.detectable_difference(0.5, 40, 48) == pytest.approx(0.35, abs=0.01)
    assert bench.detectable_difference(0.5, 120, 48) == pytest.approx(0.28, abs=0.01)


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


@pytest.mark.parametrize(("difference", "share"), [(0.2, 0.5), (0.05, 0.1), (0.01, 0.02), (0.3, 0.85)])
def test_the_size_to_resolve_is_the_fewest_transfers_the_detectable_difference_allows(
    difference: float, share: float
) -> None:
    """48 simulated against 120 real, grown together: at the size found the difference is resolved, one
    real transfer fewer it is not."""
    n = bench.transfers_to_resolve(difference, share, 120, 48)
    assert bench.detectable_difference(share, n, math.ceil(n * 48 / 120)) <= difference
    assert bench.detectable_difference(share, n - 1, math.ceil((n - 1) * 48 / 120)) > difference


def test_a_family_is_detectable_at_the_size_its_most_telling_change_needs() -> None:
    """Its ratio at 120 real transfers grows about as the square root of the size: a family at 0.5 needs
    about four times as many; the size is its best cell's and category's."""
    needed = bench.detectable_difference(0.3, 120, 48)
    changes = [(0.3, -0.5 * needed), (0.1, 0.0), (0.3, 0.25 * needed)]
    assert bench.detectability(changes, 120, 48) == pytest.approx(0.5)
    at = bench.detectable_at(changes, 120, 48)
    assert at == bench.transfers_to_resolve(0.5 * needed, 0.3, 120, 48)
    assert at == pytest.approx(4 * 120, rel=0.02)


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
