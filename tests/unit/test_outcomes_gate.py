"""The gate before any fit: each fit cell's placed rate is the primary test, its phase rows say where, and
open it alone where no placed rate does (`gate`)."""

from __future__ import annotations

from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.gate import gate
from pegbt.sim2real.outcomes.intervals import least_p
from pegbt.sim2real.outcomes.locate import locate
from pegbt.sim2real.outcomes.simulate import SimCounts

UNCALIBRATED = ("unilateral", "uncalibrated")
CALIBRATED = ("unilateral", "calibrated")


def _sim(**counts: int) -> SimCounts:
    sim = SimCounts()
    sim.counts.update(counts)
    return sim


def _chamfer_cells() -> tuple[list[Cell], dict[tuple[str, str], SimCounts]]:
    """Chamfer capture 3.2 mm at 1,104 real transfers, seed 0 of the bench, against the default world's
    442 located (the sim-to-real guide): placed p = 0.014, sense p = 0.020, the other phases far from it."""
    cells = [
        Cell(*UNCALIBRATED, 1104, 133, 4.0, {"sense": 393, "grasp": 55, "lift": 410, "lower": 113}),
        Cell(*CALIBRATED, 1104, 1104, 4.0, {}),
    ]
    sims = {
        UNCALIBRATED: _sim(placed=34, sense=186, grasp=20, lift=155, lower=47),
        CALIBRATED: _sim(placed=111),
    }
    return cells, sims


def test_a_placed_rate_that_disagrees_opens_the_gate_where_every_row_together_did_not() -> None:
    cells, sims = _chamfer_cells()
    assert not any(row.disagrees for row in locate(cells, sims))  # the gate before: BH over six rows
    opened = gate(cells, sims)
    assert opened.loud == (UNCALIBRATED,)
    assert opened.phases is None  # no phase row beyond chance: every kind is profiled


def test_a_phase_row_opens_the_gate_only_where_no_placed_rate_does() -> None:
    """Placed 30 of 120 against 12 of 48 agrees; the lift (0 against 20 of 48) disagrees: a world that
    moves failures between phases and places as many. The calibrated cell's placed rate disagreeing
    instead opens the gate there alone, its phases read only in it."""
    moved = Cell(*UNCALIBRATED, 120, 30, 4.0, {"lift": 0, "lower": 90})
    sims = {UNCALIBRATED: _sim(placed=12, lift=20, lower=16), CALIBRATED: _sim(placed=48)}
    opened = gate([moved], sims)
    assert opened.loud == (UNCALIBRATED,)
    assert opened.phases == frozenset({"lift", "lower"})
    dropping = Cell(*CALIBRATED, 120, 90, 4.0, {"lower": 30})
    opened = gate([moved, dropping], sims)
    assert opened.loud == (CALIBRATED,)
    assert opened.phases == frozenset({"lower"})
    agreeing = Cell(*UNCALIBRATED, 120, 30, 4.0, {"lift": 50, "lower": 40})
    assert not gate([agreeing], sims).opens


def test_the_phase_rows_of_an_opened_cell_say_where_it_disagrees() -> None:
    """The concealed campaign's uncalibrated cell (a bending peg): the lift and the lowering disagree,
    and so, judged among its phase rows alone, does sense."""
    cell = Cell(*UNCALIBRATED, 120, 34, 4.0, {"sense": 25, "grasp": 7, "lift": 0, "lower": 52, "release": 2})
    sims = {UNCALIBRATED: _sim(placed=5, sense=19, grasp=2, lift=18, lower=4)}
    opened = gate([cell], sims)
    assert opened.loud == (UNCALIBRATED,)
    assert opened.phases == frozenset({"lift", "lower", "sense"})


def test_without_phases_the_placed_rate_alone_decides() -> None:
    cells, sims = _chamfer_cells()
    bare = [Cell(c.variant, c.condition, c.attempted, c.succeeded) for c in cells]
    assert gate(bare, sims).loud == (UNCALIBRATED,) and gate(bare, sims).phases is None
    assert gate(cells, sims, phases=False).phases is None


def test_a_cell_that_cannot_disagree_is_not_counted_among_the_many() -> None:
    """Chamfer capture 3.2 mm at 816 real transfers, seed 0, against the default world located on 327
    (`/work/campaigns/s13/after/chamfer-816-0.out`): 96/816 placed against 25/327, p = 0.043. The calibrated
    cell placed every transfer on both sides and can give no p below 1, so the one cell that can differ is
    judged at 5 %; a calibrated cell that dropped some could differ, and the two share the 5 %."""
    uncalibrated = Cell(*UNCALIBRATED, 816, 96, 4.0, {"sense": 289, "grasp": 40, "lift": 304, "lower": 87})
    sims = {
        UNCALIBRATED: _sim(placed=25, sense=137, grasp=18, lift=114, lower=33),
        CALIBRATED: _sim(placed=327),
    }
    assert least_p((816, 816), (327, 327)) == 1.0
    assert gate([uncalibrated, Cell(*CALIBRATED, 816, 816, 4.0, {})], sims).loud == (UNCALIBRATED,)
    dropping = Cell(*CALIBRATED, 816, 806, 4.0, {"lower": 10})
    assert least_p((806, 816), (327, 327)) < 0.05
    assert not gate([uncalibrated, dropping], sims).opens
