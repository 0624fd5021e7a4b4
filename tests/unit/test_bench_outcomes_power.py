"""`pegbt bench sim2real-outcomes` sizes each family's "real" campaign before any diagnosis, by the power
to see its world in the fit cells: at least the concealed campaign's 120 transfers, in whole trials, and
as many as its least visible concealed effect needs; a world that changes no fit cell is a further null,
its naming not applicable."""

from __future__ import annotations

import pytest

from pegbt.bench import sim2real_outcomes as bench
from pegbt.sim2real.outcomes.cells import Outcomes
from pegbt.sim2real.outcomes.diagnose import Diagnosis
from tests.outcomes_helpers import fake_mapper


@pytest.mark.parametrize(
    ("needed", "size"),
    [
        ([40], 120),
        ([396], 396),
        ([432], 432),
        ([1102], 1104),
        ([None], 120),
        ([40, 1102], 1104),
        ([None, 200], 204),
    ],
)
def test_a_fit_cell_is_as_many_whole_trials_as_the_least_visible_effect_needs(
    needed: list[int | None], size: int
) -> None:
    """The last full run's `detectable_at`: grip 396, depth bias 432, chamfer 1,102 (and the pair with it)."""
    assert bench.fit_size(needed) == size


def test_the_fit_cells_get_the_planned_size_and_the_held_out_cells_the_campaigns(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """On the stand-in simulator a bending peg needs more real transfers than the 12 asked for, so its fit
    cells get its `detectable_at` in whole trials (the pair, whose chamfer shows nothing, the same); the
    held-out cells keep 12; chamfers change nothing there, so naming them is not applicable, while what
    was named on them still counts as a false discovery."""
    seen: list[Outcomes] = []
    diagnose = bench.diagnose

    def recorded(outcomes: Outcomes, *args: object) -> Diagnosis:
        seen.append(outcomes)
        return diagnose(outcomes, *args)  # type: ignore[arg-type]

    families = ["peg_compliance", "chamfer_capture", "peg_and_chamfer"]
    plans = bench.plan(fake_mapper, families, 12, bench.SETTINGS)
    assert plans["peg_compliance"].detectable_at and plans["peg_compliance"].detectable_at > 12
    assert plans["chamfer_capture"].detectable_at is None
    pair, peg = plans["peg_and_chamfer"], plans["peg_compliance"]
    assert (pair.detectability, pair.detectable_at, pair.size) == (0.0, peg.detectable_at, peg.size)
    monkeypatch.setattr(bench, "diagnose", recorded)
    figures = bench.measure(families, 1, 12, bench.SETTINGS, simulator=fake_mapper)
    size = bench.fit_size([plans["peg_compliance"].detectable_at], 12)
    assert [figures[f"{f}_real_transfers_per_fit_cell"] for f in families] == [size, 12, size]
    sizes = [{c.key: c.attempted for c in o.cells} for o in seen]
    for cells, fit in zip(sizes, (size, 12, size)):
        assert cells == {key: fit if key[0] == "unilateral" else 12 for key in bench.CELLS}
    assert figures["chamfer_capture_named"] == "n/a" and figures["chamfer_capture_resolved"] == "n/a"
    assert isinstance(figures["chamfer_capture_false"], float)
    assert isinstance(figures["peg_compliance_named"], float)
    assert figures["peg_compliance_pilot_transfers_per_fit_cell"] == peg.read_from >= peg.detectable_at
    assert figures["peg_compliance_too_large"] == figures["chamfer_capture_too_large"] == "false"
