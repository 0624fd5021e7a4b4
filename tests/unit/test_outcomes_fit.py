"""The task-level fit's statistics on a simulator with known answers: intervals, naming, the null, and
predictions of cells the fit never saw."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.fit import FITTED, PHASES_OF, fit
from pegbt.sim2real.outcomes.intervals import beyond_chance, mixture_pmf, predictive_interval, rate_interval
from pegbt.sim2real.outcomes.predict import predict_null, transfers_to_keep
from pegbt.sim2real.outcomes.simulate import simulate_cells
from pegbt.sim2real.outcomes.transfer_result import TransferResult
from tests.outcomes_helpers import fake_mapper, logged_cell


def test_exact_intervals_match_the_papers_counts():
    low, high = rate_interval(37, 68)
    assert low == pytest.approx(0.42, abs=0.01) and high == pytest.approx(0.66, abs=0.01)
    low, high = rate_interval(14, 79)
    assert low == pytest.approx(0.10, abs=0.01) and high == pytest.approx(0.28, abs=0.01)


def test_a_predictive_interval_is_wider_than_the_binomial_alone():
    certain = mixture_pmf(100, np.array([[5000.0, 10000.0]]), np.ones(1))
    unsure = mixture_pmf(100, np.array([[3.0, 10.0], [7.0, 10.0]]), np.ones(2))
    _, low_c, high_c = predictive_interval(certain)
    _, low_u, high_u = predictive_interval(unsure)
    assert 0.38 <= low_c <= 0.42 and 0.58 <= high_c <= 0.62
    assert high_u - low_u > high_c - low_c + 0.2


def test_benjamini_hochberg_keeps_what_is_beyond_chance():
    assert beyond_chance([0.001, 0.5, 0.04, 0.9]) == [True, False, False, False]


def _outcomes(world: WorldEffects, seed: int, attempted: int = 80) -> Outcomes:
    cells = [
        logged_cell(world, v, c, attempted, seed + i)
        for i, (v, c) in enumerate(
            [(v, c) for v in ("unilateral", "bilateral", "handover") for c in ("uncalibrated", "calibrated")]
        )
    ]
    return Outcomes(tuple(cells), "test")


def test_a_concealed_effect_is_named_with_its_parameter_and_held_out_cells_predicted():
    hidden = WorldEffects.of({"peg_compliance": {"deflection": 0.0018}})
    outcomes = _outcomes(hidden, seed=3)
    d = diagnose(outcomes, Settings(fit="unilateral", transfers=200, points=5, phases=True), fake_mapper)
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"]
    low, high = d.verdict.named[0].interval()
    assert low <= 0.0018 <= high
    assert abs(d.verdict.named[0].value - 0.0018) <= 0.3 * 0.0018
    assert {c.variant for c in d.held_out} == {"bilateral", "handover"}
    assert all(d.predictions[c.key].inside for c in d.held_out)


def test_held_out_cells_never_reach_the_fit():
    hidden = WorldEffects.of({"peg_compliance": {"deflection": 0.0018}})
    outcomes = _outcomes(hidden, seed=3)
    changed = Outcomes(
        tuple(
            c if c.variant == "unilateral" else Cell(c.variant, c.condition, c.attempted, 0)
            for c in outcomes.cells
        ),
        "test",
    )
    settings = Settings(fit="unilateral", transfers=200, points=5)
    first, second = diagnose(outcomes, settings, fake_mapper), diagnose(changed, settings, fake_mapper)
    assert first.verdict.named[0].value == second.verdict.named[0].value
    bilateral = ("bilateral", "uncalibrated")
    assert first.predictions[bilateral].inside and not second.predictions[bilateral].inside


def test_the_default_world_names_nothing():
    outcomes = _outcomes(WorldEffects(), seed=11)
    d = diagnose(outcomes, Settings(fit="all", transfers=200, points=5), fake_mapper)
    assert d.verdict.named == () and d.verdict.tied == ()


def test_a_way_back_lost_at_sense_is_fitted_like_any_other_phase():
    """A trial's way back fails at sense where its way out lost the block; the phase simulator now does
    too, so a world that loses them there explains a real cell with sense failures better than one that
    calls them grasp failures."""
    from pegbt.sim2real.outcomes.likelihood import log_likelihood
    from pegbt.sim2real.outcomes.simulate import SimCounts

    real = Cell("unilateral", "uncalibrated", 36, 11, failures={"grasp": 5, "lower": 12, "sense": 8})
    at_sense, at_grasp = SimCounts(), SimCounts()
    at_sense.counts.update(placed=110, grasp=50, lower=120, sense=80)
    at_grasp.counts.update(placed=110, grasp=130, lower=120)
    assert log_likelihood(real, at_sense) > log_likelihood(real, at_grasp) + 5


def test_each_transfer_is_simulated_once_per_world_in_one_batch_per_transfer():
    """The diagnosis asks for a (world, transfer) at most once, and the fit hands every candidate's grid
    over as one task per transfer, so one process can replay the arm's motion across all of them."""
    asked: list[tuple[object, str, str, int]] = []
    widest = 0

    def recording(tasks):
        nonlocal widest
        for worlds, variant, condition, seed in tasks:
            asked.extend((w, variant, condition, seed) for w in worlds)
            widest = max(widest, len(worlds))
        return fake_mapper(tasks)

    hidden = WorldEffects.of({"peg_compliance": {"deflection": 0.0018}})
    diagnose(_outcomes(hidden, seed=3), Settings(fit="unilateral", transfers=20, points=5), recording)
    assert len(asked) == len(set(asked))
    assert widest >= 5 * 2  # at least two candidates' grids in one task


@pytest.mark.parametrize(
    ("phases", "kinds"),
    [
        ({"sense"}, set(FITTED)),
        ({"sense", "grasp"}, set(FITTED)),
        ({"grasp"}, {k for k, acts in PHASES_OF.items() if "grasp" in acts}),
    ],
)
def test_a_disagreement_at_sense_admits_every_kind(phases: set[str], kinds: set[str]) -> None:
    """A way back fails at sense where its way out lost the block, which any kind can cause: a real cell
    that disagrees at sense (a chamfer that places more on the way out leaves fewer ways back empty) is
    fitted with every kind, where the phase filter once left none; a disagreement at grasp alone admits
    the kinds that act there."""
    cells = list(_outcomes(WorldEffects.of({"peg_compliance": {"deflection": 0.0018}}), seed=3).cells[:2])
    null = simulate_cells(fake_mapper, [WorldEffects()], [c.key for c in cells], 8)[0]
    verdict = fit(fake_mapper, cells, null, 8, 2, True, frozenset(phases))
    assert {p.candidate.kind for p in verdict.tried} == kinds


def test_with_nothing_named_a_row_placed_in_full_is_simulated_until_it_can_show_it_keeps():
    """The paper's calibrated rows, 120 of 120, predicted by the default world when nothing is named: each
    is simulated to the 189 transfers whose Wilson bound can reach 98 %, not left at the fit's few."""
    outcomes = _outcomes(WorldEffects(), seed=11, attempted=120)
    d = diagnose(outcomes, Settings(fit="unilateral", transfers=24, located=48, points=3), fake_mapper)
    assert d.verdict.named == () and d.verdict.tied == ()
    for cell in outcomes.cells:
        simulated = d.predictions[cell.key].at_best.attempted
        if cell.condition == "calibrated":
            assert simulated == transfers_to_keep() == 189
            assert d.predictions[cell.key].keeps >= 0.98
        else:
            assert simulated == (48 if cell.variant == "unilateral" else 24)
        assert d.before[cell.key].attempted == (48 if cell.variant == "unilateral" else 24)


def test_the_default_world_s_keep_up_goes_on_past_every_seed_held_skipped_ones_included():
    """A calibrated row under the paper's counting skips some ways back: each seed is still one transfer,
    so the keep-up starts at the first seed not yet simulated and stops at `transfers_to_keep()` seeds."""
    seeds: list[int] = []

    def skipping(tasks):
        seeds.extend(seed for *_, seed in tasks)
        return [[TransferResult(True, None, 5.0, skipped=seed % 4 == 3)] for *_, seed in tasks]

    cell = Cell("bilateral", "calibrated", 60, 60)
    null = simulate_cells(skipping, [WorldEffects()], [cell.key], 40)[0]
    assert null[cell.key].attempted == 30 and null[cell.key].skipped == 10
    seeds.clear()
    kept = predict_null(skipping, null, [cell])[cell.key].at_best
    assert seeds == list(range(40, transfers_to_keep()))
    assert kept.attempted + kept.skipped == transfers_to_keep()
    assert null[cell.key].attempted == 30  # the prediction's own counts are not the kept ones
