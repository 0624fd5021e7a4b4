"""A tie read on the fit's few simulated transfers a world is weighed again on as many as the real fit cell
holds: worlds the real counts do tell apart are then told apart, and worlds they do not stay tied."""

from __future__ import annotations

import numpy as np

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.diagnose import Settings, _resolved
from pegbt.sim2real.outcomes.fit import Candidate, Profile, Verdict
from tests.outcomes_helpers import grip_or_bend, lift_success, logged_cell, rate_mapper

PEG = Candidate("peg_compliance", "deflection", (0.0018,))
GRIP = Candidate("grip_compliance", "displacement", (0.0015,))
HIDDEN = WorldEffects.of({"peg_compliance": {"deflection": 0.0018}})
SETTINGS = Settings(fit="unilateral", transfers=12, located=48, points=4)


def _tie(unchecked: bool = False) -> Verdict:
    profiles = tuple(Profile(c, c.grid, [{}], np.zeros((1, 1))) for c in (PEG, GRIP))
    return Verdict((), profiles, profiles, np.zeros(1), (PEG.name, GRIP.name), unchecked=unchecked)


def _cells() -> list[Cell]:
    return [logged_cell(HIDDEN, "unilateral", c, 600, 7) for c in ("uncalibrated", "calibrated")]


def test_a_tie_the_real_counts_can_decide_is_decided_on_as_many_simulated_transfers() -> None:
    cells = _cells()
    assert 0.3 < cells[0].rate < 0.5
    verdict, said, _ = _resolved(rate_mapper(grip_or_bend(0.25), "lift"), _tie(), cells, SETTINGS)
    assert [p.candidate.kind for p in verdict.named] == ["peg_compliance"] and verdict.tied == ()
    assert said.startswith("The tie is decided: on 600 fresh simulated transfers a fit cell peg_compliance")


def test_worlds_that_place_alike_stay_tied() -> None:
    verdict, said, _ = _resolved(
        rate_mapper(grip_or_bend(lift_success(HIDDEN, "unilateral", "uncalibrated")), "lift"),
        _tie(),
        _cells(),
        SETTINGS,
    )
    assert verdict.named == () and len(verdict.tied) == 2 and said.startswith("The tie stands")


def test_an_unchecked_tie_decided_keeps_one_explanation_and_names_none() -> None:
    verdict, _, _ = _resolved(
        rate_mapper(grip_or_bend(0.25), "lift"), _tie(unchecked=True), _cells(), SETTINGS
    )
    assert verdict.named == () and [p.candidate.kind for p in verdict.tied] == ["peg_compliance"]


def test_a_tied_path_decided_is_named_whole() -> None:
    chamfer = Candidate("chamfer_capture", "capture_radius", (0.0032,))
    first = Profile(PEG, PEG.grid, [{}], np.zeros((1, 1)))
    end = Profile(chamfer, chamfer.grid, [{}], np.zeros((1, 1)), base=first.world())
    grip = Profile(GRIP, GRIP.grid, [{}], np.zeros((1, 1)))
    tie = Verdict(
        (), (grip, end), (first, grip), np.zeros(1), (PEG.name, GRIP.name), paths=((grip,), (first, end))
    )
    verdict, said, dropped = _resolved(rate_mapper(grip_or_bend(0.25), "lift"), tie, _cells(), SETTINGS)
    assert said.startswith("The tie is decided") and verdict.tied == () and dropped == ()
    assert [p.candidate.kind for p in verdict.named] == ["peg_compliance", "chamfer_capture"]
    assert {e.kind for e in verdict.world()} == {"peg_compliance", "chamfer_capture"}
