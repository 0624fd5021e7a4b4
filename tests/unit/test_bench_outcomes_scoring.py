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


def _tied(*ends: tuple[str, str], paths: tuple[tuple[int, ...], ...] = ()) -> Diagnosis:
    """A diagnosis that names nothing and holds `ends` (kind, parameter) in a tie; `paths`: indices into
    `ends` of a tied end's path, its end last."""
    grid = (0.001, 0.002, 0.003)
    profiles = tuple(
        Profile(Candidate(kind, parameter, grid), grid, [], np.array([-1.0, 0.0, -1.0])[:, None])
        for kind, parameter in ends
    )
    tied = tuple(profiles[path[-1]] for path in paths) if paths else profiles
    verdict = Verdict(
        (), tied, profiles, np.zeros(1), (), paths=tuple(tuple(profiles[i] for i in p) for p in paths)
    )
    return Diagnosis(None, Settings(), (), (), {}, [], verdict, {})  # type: ignore[arg-type]


def test_a_concealed_effect_held_in_a_tie_is_scored_tied_not_named_nor_false() -> None:
    """The grip's seed 1: a yielding grip and a registration offset tied, neither named. The naming rate
    counts it a miss; `tied` says the report held the truth among worlds the data could not tell apart."""
    d = _tied(("grip_compliance", "displacement"), ("registration_offset", "x"))
    figures = bench.score(d, {"grip_compliance": {"displacement": 0.0012}})
    assert (figures["named"], figures["tied"], figures["false"]) == (0, 1, 0)
    assert bench.score(d, {"peg_compliance": {"deflection": 0.0012}})["tied"] == 0  # the truth not among them
    assert bench.score(d, {})["tied"] == 0  # the null: nothing concealed to tie


def test_a_pair_is_tied_only_when_one_tied_path_holds_both_its_effects() -> None:
    """Two concealed effects count as tied when a tied end's path (the effects added on the way) holds
    both, not when each sits in a different tied world."""
    ends = (
        ("peg_compliance", "deflection"),
        ("chamfer_capture", "capture_radius"),
        ("hole_lobes", "lobe_radius"),
    )
    pair = {"peg_compliance": {"deflection": 0.0012}, "chamfer_capture": {"capture_radius": 0.0032}}
    assert bench.score(_tied(*ends, paths=((0, 1), (2,))), pair)["tied"] == 1
    assert bench.score(_tied(*ends, paths=((0,), (1,))), pair)["tied"] == 0
