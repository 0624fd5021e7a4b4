"""The fit's resolution at a large campaign: every candidate screened on the grid's transfers against the
world before it on the same seeds, the leaders weighed again on the default world's located transfers
(`leaders_to_weigh`, `fit`'s `weighed`)."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.fit import LR_95, Candidate, Profile, fit, leaders_to_weigh
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.report import report_markdown
from pegbt.sim2real.outcomes.simulate import simulate_cells
from tests.outcomes_helpers import chamfer_mapper, chamfer_placed

HIDDEN = WorldEffects.of({"chamfer_capture": {"capture_radius": 0.0032}})
SETTINGS = Settings(fit="unilateral", transfers=12, located=48, points=4)
UNCALIBRATED = ("unilateral", "uncalibrated")


def _profile(name: str, gain: float) -> Profile:
    """A screened candidate whose best grid value fits `gain` log units better than the world before it."""
    per_cell = np.array([[-11.0 + gain], [-10.0 + gain]])
    return Profile(Candidate(name, "p", (1.0, 2.0)), (1.0, 2.0), [], per_cell, reference=np.array([-10.0]))


def test_the_leaders_are_within_the_chi2_margin_of_the_best_and_other_gains_are_probed() -> None:
    margin = LR_95 / 2
    screened = [
        _profile("a", 5.0),
        _profile("b", 5.0 - margin + 0.01),
        _profile("c", 0.5),
        _profile("d", -0.5),
    ]
    near, probed = leaders_to_weigh(screened)
    assert [p.candidate.kind for p in near] == ["a", "b"]
    assert [p.candidate.kind for p in probed] == ["c"]
    near, probed = leaders_to_weigh(
        [_profile("e", 0.0), _profile("f", -margin + 0.01), _profile("g", -margin - 0.01)]
    )
    assert ([p.candidate.kind for p in near], probed) == (["e", "f"], [])
    assert leaders_to_weigh([]) == ([], [])


def _cells(seed: int, fit_transfers: int = 1104) -> list[Cell]:
    cells = []
    for v in ("unilateral", "bilateral", "handover"):
        for c in ("uncalibrated", "calibrated"):
            n = fit_transfers if v == "unilateral" else 120
            placed = int(np.random.default_rng([seed, 5]).binomial(n, chamfer_placed(HIDDEN, v, c)))
            cells.append(Cell(v, c, n, placed, 4.0, {"lower": n - placed} if n > placed else {}))
    return cells


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_four_point_change_at_1104_is_named_once_the_leaders_are_weighed(seed: int) -> None:
    """12 % placed against the default world's 7.7 %, 1,104 real transfers: on the grid's 111 simulated
    transfers against the default world's 442 no candidate beats it; weighed on 442 the chamfer does."""
    fit_cells = _cells(seed)[:2]
    null = simulate_cells(chamfer_mapper, [WorldEffects()], [c.key for c in fit_cells], 442)[0]
    screened_only = fit(chamfer_mapper, fit_cells, null, 111, 4, True, None, 1)
    weighed = fit(chamfer_mapper, fit_cells, null, 111, 4, True, None, 1, weighed=442)
    assert screened_only.named == ()
    assert [p.candidate.kind for p in weighed.named] == ["chamfer_capture"]
    assert abs(weighed.named[0].estimate - 0.0032) <= 0.3 * 0.0032


def test_the_diagnosis_weighs_only_its_leaders_on_the_located_transfers() -> None:
    """Only chamfers change the stand-in's outcomes, so every other candidate's paired gain is 0: it is
    screened on 111 transfers and never weighed; the chamfer is weighed on 442 and named."""
    d = diagnose(Outcomes(tuple(_cells(0)), "stand-in robot"), SETTINGS, chamfer_mapper)
    assert (d.settings.transfers, d.settings.located) == (111, 442)
    assert [p.candidate.kind for p in d.verdict.named] == ["chamfer_capture"]
    weighed_on = {p.candidate.name: p.sims[0][UNCALIBRATED].attempted for p in d.verdict.tried}
    assert weighed_on.pop("chamfer_capture.capture_radius") == 442
    assert set(weighed_on.values()) == {111}
    assert d.verdict.tested == ("chamfer_capture.capture_radius",)  # the others trailed it, never tested
    rows = [line for line in report_markdown(d, []).splitlines() if line.startswith("| peg_compliance.")]
    assert rows and rows[0].endswith("| not tested: trailed the leaders |")


def _lucky_screen(tasks):
    """A registration offset that places as the real robot does on the screen's 16 seeds alone (luck), and a
    bending peg that places as it does everywhere but on those seeds, where it places a third as often."""
    out = []
    for worlds, variant, condition, seed in tasks:
        u = np.random.default_rng([seed, 99]).random()
        row = []
        for effects in worlds:
            rate = 1.0 if condition == "calibrated" else 0.05
            if condition == "uncalibrated" and effects.values("registration_offset")["x"] != 0.0:
                rate = 0.45 if seed < 16 else 0.05
            deflection = effects.values("peg_compliance")["deflection"]
            if condition == "uncalibrated" and deflection > 0.0:
                rate = min(0.4, 0.05 + 0.35 * deflection / 0.0012) * (0.3 if seed < 16 else 1.0)
            row.append(TransferResult(bool(u < rate), None if u < rate else "lift", 4.0))
        out.append(row)
    return out


def test_a_candidate_the_screen_trails_by_luck_is_probed_weighed_and_named() -> None:
    """On the screen's seeds a registration offset leads a bending peg far beyond the χ² margin; the peg's
    gain is still positive, so it is probed at its best screened value on the weighed transfers, rises past
    the offset there, and is weighed in full and named."""
    cells = [
        Cell("unilateral", "uncalibrated", 120, 48, failures={"lift": 72}),
        Cell("unilateral", "calibrated", 120, 120),
    ]
    null = simulate_cells(_lucky_screen, [WorldEffects()], [c.key for c in cells], 48)[0]
    screen = fit(_lucky_screen, cells, null, 16, 4, True, None, 1).tried
    gains = {p.candidate.name: p.paired_gain for p in screen}
    assert 0 < gains["peg_compliance.deflection"] < gains["registration_offset.x"] - LR_95 / 2
    verdict = fit(_lucky_screen, cells, null, 16, 4, True, None, 1, weighed=48)
    assert [p.candidate.kind for p in verdict.named] == ["peg_compliance"]
    assert verdict.named[0].sims[0][UNCALIBRATED].attempted == 48
