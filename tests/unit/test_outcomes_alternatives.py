"""An effect the fit cells cannot see (flat profile there) but which changes a held-out cell is reported as
open: not named, its allowed range given, and the held-out cells predicted without it, with it over its
whole range, and with every open effect mixed."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.alternatives import Alternative, shares
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Diagnosis, Settings, diagnose
from pegbt.sim2real.outcomes.fit import Candidate, Profile
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.report import report_dict, report_markdown
from tests.outcomes_helpers import Tasks, failing_at, rate_mapper


def _rate(effects: WorldEffects, variant: str, condition: str, capture_acts: bool) -> float:
    """Uncalibrated success rises with a bending peg in both variants; bilateral also with a wider grasp
    capture (the other arm's grasps), which unilateral never needs."""
    if condition != "uncalibrated":
        return 1.0
    bend = effects.values("peg_compliance")["deflection"] / 0.003
    capture = effects.values("grasp_capture")["width"] / 0.003 if capture_acts else 0.0
    return 0.05 + 0.4 * bend + (0.5 * capture if variant == "bilateral" else 0.0)


def _mapper(capture_acts: bool) -> Callable[[Tasks], list[list[TransferResult]]]:
    return rate_mapper(lambda e, v, c: _rate(e, v, c, capture_acts), "lift", stream=11)


CELLS = (
    failing_at("lift", "unilateral", "uncalibrated", 80, 28),
    failing_at("lift", "unilateral", "calibrated", 80, 80),
    failing_at("lift", "bilateral", "uncalibrated", 80, 50),
)


def test_an_effect_the_fit_cells_cannot_see_is_left_open_and_predicts_the_held_out_cells() -> None:
    d = diagnose(Outcomes(CELLS, "test"), Settings(fit="unilateral", transfers=120, points=3), _mapper(True))
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"]
    opened = {a.name: a for a in d.alternatives}
    assert "grasp_capture.width" in opened
    assert opened["grasp_capture.width"].value == 0.003  # every value fits the unilateral cells as well
    report = report_dict(d)
    assert "grasp_capture.width" not in {n["effect"] for n in report["named"]}
    assert any(o["candidate"] == "grasp_capture.width" for o in report["open"])
    bilateral = next(c for c in report["cells"] if c["variant"] == "bilateral")
    with_capture = bilateral["predicted_by"]["grasp_capture.width over 0–0.003"]["rate"]
    without = bilateral["predicted_by"]["peg_compliance"]["rate"]
    # over a width the unilateral cells cannot pin, bilateral gains half of what the widest capture gives
    assert 0.15 < with_capture - without < 0.35
    assert bilateral["predicted_by"]["what is open, mixed"]["rate"] > without + 0.1
    assert abs(sum(o["share"] for o in report["open"]) - 1.0) < 1e-9
    markdown = report_markdown(d)
    assert "leave open" in markdown and "Across the tie" not in markdown  # the named world predicts
    assert "Across the worlds above (the span of their rates; predicted with peg_compliance)" in markdown


def test_an_open_effect_that_changes_no_held_out_cell_is_not_reported() -> None:
    d = diagnose(Outcomes(CELLS, "test"), Settings(fit="unilateral", transfers=120, points=3), _mapper(False))
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"]
    assert "grasp_capture.width" not in {a.name for a in d.alternatives}


def test_one_informative_count_leaves_open_what_decides_a_held_out_cell() -> None:
    """The paper's table: placed counts alone, one loud fit cell. The bending peg explains it, unnamed; the
    grasp capture, which unilateral never needs, is still left open on top of it and predicts bilateral."""
    table = Outcomes(tuple(Cell(c.variant, c.condition, c.attempted, c.succeeded) for c in CELLS), "table")
    d = diagnose(table, Settings(fit="unilateral", transfers=120, points=3), _mapper(True))
    assert d.verdict.unchecked and [t.candidate.kind for t in d.verdict.tied] == ["peg_compliance"]
    assert "grasp_capture.width" in {a.name for a in d.alternatives}
    bilateral = ("bilateral", "uncalibrated")
    with_capture = d.predicted_by["grasp_capture.width over 0–0.003"][bilateral].rate
    assert with_capture > d.predicted_by["peg_compliance"][bilateral].rate + 0.15
    assert d.predicted_by["peg_compliance"][bilateral] == d.predictions[bilateral]
    markdown = report_markdown(d)
    assert "Explained, not named" in markdown and "leave open" in markdown


def test_the_open_mixture_weighs_an_effect_by_how_much_of_its_range_the_fit_cells_allow() -> None:
    """Two open effects, each fitting as well as the world without it at its default: one fits as well over
    its whole range, the other is excluded over the top half of it; the second, with 3 of 5 values allowed, weighs
    3/8 of the mix, not a half."""
    values = np.linspace(0.0, 0.003, 5)
    flat = np.zeros(5)
    half = np.array([0.0, 0.0, 0.0, -50.0, -50.0])
    opened = [
        Alternative(
            Profile(
                Candidate(kind, "width", tuple(values[1:])),
                tuple(values[1:]),
                [],
                t[1:, None],
                dense=(values, t),
            ),
            tuple(values[1:]),
            0.003,
        )
        for kind, t in (("grasp_capture", flat), ("jaw_tip_slide", half))
    ]
    assert opened[0].profile.evidence() == pytest.approx(0.0)
    assert opened[1].profile.evidence() == pytest.approx(np.log(3 / 5), abs=1e-9)
    assert shares(opened) == pytest.approx([5 / 8, 3 / 8])
    assert list(shares([])) == []
    # an effect profiled by two parameters weighs as one effect, not two
    y = Alternative(
        replace(opened[0].profile, candidate=Candidate("grasp_capture", "y", ())), (0.003,), 0.003
    )
    assert shares([opened[0], y, opened[1]]) == pytest.approx([5 / 16, 5 / 16, 3 / 8])


def _harmful_rate(effects: WorldEffects, variant: str, condition: str) -> float:
    """As `_rate` with the capture acting, but a grasp capture wider than 1.5 mm costs the calibrated arm
    most of its grasps (a yielding wrist that lets a calibrated grasp slip)."""
    if condition != "uncalibrated":
        return 0.3 if effects.values("grasp_capture")["width"] > 0.0015 else 1.0
    return _rate(effects, variant, condition, True)


def test_an_open_effects_posterior_excludes_the_values_the_calibrated_fit_cells_exclude() -> None:
    """The calibrated unilateral cell placed all 80: an open grasp capture above 1.5 mm, which would cost it
    most of them, keeps no weight in the effect's posterior, though the uncalibrated cell alone (the
    informative one) cannot see it; so it predicts a held-out calibrated cell placing as it does."""
    d = diagnose(
        Outcomes((*CELLS, failing_at("lift", "bilateral", "calibrated", 80, 80)), "test"),
        Settings(fit="unilateral", transfers=120, points=3),
        rate_mapper(_harmful_rate, "lift", stream=11),
    )
    opened = {a.name: a for a in d.alternatives}
    capture = opened["grasp_capture.width"]
    assert capture.allowed == (0.001,)
    values, weights = capture.profile.posterior()
    assert weights[values > 0.0016].sum() < 0.01
    by_capture = d.predicted_by["grasp_capture.width over 0–0.003"]
    assert by_capture[("bilateral", "calibrated")].rate > 0.97
    assert ("unilateral", "calibrated") not in by_capture  # a fit cell: the named world predicts it


def _unexplained_rate(effects: WorldEffects, variant: str, condition: str) -> float:
    """No registered effect moves unilateral; a grasp capture raises bilateral (the other arm's grasps)."""
    if condition != "uncalibrated":
        return 1.0
    capture = effects.values("grasp_capture")["width"] / 0.003
    return 0.2 + (0.5 * capture if variant == "bilateral" else 0.0)


def _diagnosed_with_unilateral_placing(placed: int) -> Diagnosis:
    """`placed` of 80 unilateral uncalibrated transfers (the default world places a fifth), fitted on
    unilateral; bilateral uncalibrated (40 of 80) held out."""
    cells = (
        failing_at("lift", "unilateral", "uncalibrated", 80, placed),
        failing_at("lift", "unilateral", "calibrated", 80, 80),
        failing_at("lift", "bilateral", "uncalibrated", 80, 40),
    )
    return diagnose(
        Outcomes(cells, "test"),
        Settings(fit="unilateral", transfers=120, points=3),
        rate_mapper(_unexplained_rate, "lift", stream=11),
    )


def test_fit_cells_that_reject_the_default_world_unexplained_are_predicted_with_what_they_leave_open() -> (
    None
):
    """The unilateral cell places 48 of 80 where the default world places a fifth: the gate opens, no
    effect explains it, and the held-out bilateral cell is predicted with the open grasp capture mixed in,
    not with the default world the fit cells reject (which is still shown beside it)."""
    d = _diagnosed_with_unilateral_placing(48)
    assert d.verdict.tried and not d.verdict.named and not d.verdict.tied
    assert "grasp_capture.width" in {a.name for a in d.alternatives}
    bilateral = ("bilateral", "uncalibrated")
    mixed, default = d.predicted_by["what is open, mixed"], d.predicted_by["default world"]
    assert d.predictions[bilateral] == mixed[bilateral]
    assert mixed[bilateral].rate > default[bilateral].rate + 0.05
    assert not default[bilateral].inside
    report = report_dict(d)
    cell = next(c for c in report["cells"] if c["variant"] == "bilateral")
    assert cell["predicted"]["rate"] == mixed[bilateral].rate
    assert cell["simulated_after_pooled"] and d.pools_after  # its "after": effective transfers, pooled
    markdown = report_markdown(d)
    assert "Predicted with what is open, mixed." in markdown
    assert "rejects the default world" in markdown and "the mixture is the prediction (Prove)" in markdown


def test_fit_cells_that_do_not_reject_the_default_world_are_predicted_with_it() -> None:
    """The same cells with unilateral as the default world places it: no fit, nothing open, and the
    held-out cell is predicted by the default world."""
    d = _diagnosed_with_unilateral_placing(16)
    assert not d.verdict.tried and not d.alternatives and not d.predicted_by
    assert "Predicted with the default world." in report_markdown(d)
    assert not d.pools_after and "effective transfers" not in report_markdown(d)
