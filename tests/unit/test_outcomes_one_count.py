"""One informative count (the paper's table: one cell disagrees, no phases): an effect that fits it beyond
chance is kept as an explanation and predicts the other cells, but is not named, since no fit cell is left
to hold out; one that does not hold on fresh seeds explains nothing; and a quiet fit cell, which the
candidate leaves as it is, costs it nothing."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import FRESH_SEED, Settings, diagnose
from pegbt.sim2real.outcomes.fit import LR_95, Candidate, Profile, candidates, profile
from pegbt.sim2real.outcomes.likelihood import log_likelihood
from pegbt.sim2real.outcomes.report import report_dict, report_markdown
from pegbt.sim2real.outcomes.simulate import Mapper, Task, simulate_cells
from pegbt.sim2real.outcomes.transfer_result import TransferResult
from tests.outcomes_helpers import (
    failing_at,
    fake_mapper,
    lift_success,
    logged_cell,
    rate_mapper,
    real_counts,
)

HIDDEN = WorldEffects.of({"peg_compliance": {"deflection": 0.0018}})
KEYS = [(v, c) for v in ("unilateral", "bilateral", "handover") for c in ("uncalibrated", "calibrated")]
SETTINGS = Settings(fit="unilateral", transfers=200, points=5)


def _table(world: WorldEffects) -> Outcomes:
    """Placed counts alone, as the paper's table gives them."""
    return Outcomes(
        tuple(Cell(v, c, 80, real_counts(world, v, c, 80, 3 + i)) for i, (v, c) in enumerate(KEYS)), "table"
    )


def test_one_informative_count_explains_but_names_nothing_and_predicts_with_the_explanation() -> None:
    d = diagnose(_table(HIDDEN), SETTINGS, fake_mapper)
    assert d.verdict.named == () and d.verdict.unchecked
    assert [t.candidate.kind for t in d.verdict.tied] == ["peg_compliance"]
    bilateral = ("bilateral", "uncalibrated")
    assert d.predictions[bilateral].inside  # the default world places 10 %, the real robot far more
    assert d.predictions[bilateral].rate > 0.3
    report = report_dict(d)
    assert report["named"] == [] and report["unchecked"] is True
    assert [t["effect"] for t in report["indistinguishable"]] == ["peg_compliance"]
    markdown = report_markdown(d)
    assert "Explained, not named" in markdown
    assert d.predicted_by == {} and "Across the tie" not in markdown  # one world: no span to give


def test_the_same_cells_with_their_failures_per_phase_name_the_effect() -> None:
    logged = Outcomes(tuple(logged_cell(HIDDEN, v, c, 80, 3 + i) for i, (v, c) in enumerate(KEYS)), "logs")
    d = diagnose(logged, SETTINGS, fake_mapper)
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"] and not d.verdict.unchecked


def _peg_with_a_quiet_cell(mapper: Mapper) -> tuple[list[Cell], np.ndarray, Candidate, Profile]:
    """The bending peg profiled on a loud unilateral cell (300 transfers) and a quiet calibrated one (20),
    against the default world on 300: the cells, the default world's log-likelihoods, the candidate and its
    profile."""
    cells = [
        logged_cell(HIDDEN, "unilateral", "uncalibrated", 400, 1),
        logged_cell(HIDDEN, "unilateral", "calibrated", 400, 2),
    ]
    before = simulate_cells(mapper, [WorldEffects()], [c.key for c in cells], 300)[0]
    null = np.array([log_likelihood(c, before[c.key], True) for c in cells])
    peg = next(c for c in candidates(4) if c.kind == "peg_compliance")
    return cells, null, peg, profile(mapper, peg, cells, 300, null, informative=1, quiet_transfers=20)


def test_a_quiet_cell_the_candidate_leaves_as_it_is_keeps_the_world_befores_likelihood() -> None:
    """The calibrated cell is simulated on a third of the fit's transfers; weighed on its own there it
    would fall below the default world's (simulated on more) for the imprecision alone."""
    cells, null, peg, fitted = _peg_with_a_quiet_cell(fake_mapper)
    assert fitted.per_cell.shape == (len(peg.grid), 2)
    assert all(cells[1].key in sim for sim in fitted.sims)  # the quiet cell was simulated
    assert np.allclose(fitted.per_cell[:, 1], null[1])
    on_its_own = profile(
        fake_mapper, Candidate(peg.kind, peg.parameter, peg.grid), cells[1:], 20, null[1:], 1
    )
    assert on_its_own.per_cell[:, 0].max() < null[1]


def _spoiling(world: WorldEffects, variant: str, condition: str) -> float:
    """`lift_success`, where a bending peg also drops calibrated lifts, half of them at 3 mm."""
    if condition == "calibrated":
        return 1.0 - 0.5 * world.values("peg_compliance")["deflection"] / 0.003
    return lift_success(world, variant, condition)


def test_a_quiet_cell_the_candidate_spoils_costs_it_what_it_drops_there() -> None:
    _, null, _, fitted = _peg_with_a_quiet_cell(rate_mapper(_spoiling, "lift"))
    quiet = fitted.per_cell[:, 1] - null[1]
    assert quiet[-1] < -LR_95 and np.all(np.diff(quiet) <= 0)  # the more it bends, the more it costs


def _lucky_on_the_fits_seeds(tasks: Sequence[Task]) -> list[list[TransferResult]]:
    """`fake_mapper`, where every world is the default one on the replication's fresh seeds: an effect
    that fitted only by the luck of the fit's own simulations."""
    return fake_mapper(
        [
            (w if seed < FRESH_SEED else tuple(WorldEffects() for _ in w), v, c, seed)
            for w, v, c, seed in tasks
        ]
    )


def test_an_explanation_that_does_not_hold_on_fresh_seeds_leaves_nothing_explained() -> None:
    d = diagnose(_table(HIDDEN), SETTINGS, _lucky_on_the_fits_seeds)
    assert d.unreplicated == ("peg_compliance.deflection",)
    assert d.verdict.named == () and d.verdict.tied == () and not d.verdict.unchecked
    assert report_dict(d)["unchecked"] is False
    assert "Explained, not named" not in report_markdown(d)


def test_phases_of_held_out_cells_alone_leave_the_fit_cells_one_count() -> None:
    """Failures per phase in the cells the fit never sees tell the fit's candidates nothing apart."""
    cells = tuple(
        Cell(v, c, 80, real_counts(HIDDEN, v, c, 80, 3 + i))
        if v == "unilateral"
        else logged_cell(HIDDEN, v, c, 80, 3 + i)
        for i, (v, c) in enumerate(KEYS)
    )
    d = diagnose(Outcomes(cells, "mixed"), SETTINGS, fake_mapper)
    assert d.verdict.named == () and d.verdict.unchecked


def test_phases_of_a_quiet_fit_cell_leave_the_loud_one_one_count() -> None:
    cells = (
        Cell("unilateral", "uncalibrated", 80, real_counts(HIDDEN, "unilateral", "uncalibrated", 80, 3)),
        failing_at("lift", "unilateral", "calibrated", 80, 78),
        *(logged_cell(HIDDEN, v, c, 80, 5 + i) for i, (v, c) in enumerate(KEYS[2:])),
    )
    d = diagnose(Outcomes(cells, "mixed"), SETTINGS, fake_mapper)
    assert [r.phase for r in d.rows if r.variant == "unilateral" and r.phase] == ["lift"]  # the quiet cell's
    assert d.verdict.named == () and d.verdict.unchecked


def test_placed_counts_alone_name_the_effect_where_several_fit_cells_disagree() -> None:
    """Fitted on the uncalibrated rows, the table's three counts hold each out in turn."""
    settings = Settings(fit="uncalibrated", transfers=200, points=5)
    d = diagnose(_table(HIDDEN), settings, fake_mapper)
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"] and not d.verdict.unchecked
