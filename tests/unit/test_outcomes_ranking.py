"""The additions that pass are ranked on fresh seeds: an effect whose grid drew the luckiest outcomes on the
fit's own seeds is not the first choice, and does not stand in for the true effect. The concealed campaign
of 2026-11-29 named a registration offset first (its 16 simulated transfers a cell favoured it), where on
48 fresh transfers the bending peg the runs were made with fitted far better."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Outcomes
from pegbt.sim2real.outcomes.diagnose import FRESH_SEED, Settings, diagnose
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.report import report_dict, report_markdown
from pegbt.sim2real.outcomes.simulate import Mapper
from tests.outcomes_helpers import failing_at

CELLS = [(v, c) for v in ("unilateral", "bilateral") for c in ("uncalibrated", "calibrated")]
SETTINGS = Settings(fit="unilateral", transfers=16, located=48, points=4)


def _placed(world: WorldEffects, condition: str, seed: int, peg: float, offset: float) -> bool:
    """Of the uncalibrated transfers, a bending peg places the share `peg` at random; an offset alone
    places exactly every other one on the seeds the fit simulates (the luckiest draw a grid can make) and
    the share `offset` on any other; the default world one in twenty."""
    if condition != "uncalibrated":
        return True
    u = np.random.default_rng([seed, 7]).random()
    if world.values("peg_compliance")["deflection"] > 0:
        return bool(u < peg)
    moved = world.values("registration_offset")
    if moved["x"] or moved["y"]:
        return seed % 2 == 0 if seed < FRESH_SEED else bool(u < offset)
    return bool(u < 0.05)


def _mapper(peg: float, offset: float) -> Mapper:
    def mapper(tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]]) -> list[list[TransferResult]]:
        out = []
        for worlds, _variant, condition, seed in tasks:
            placed = [_placed(world, condition, seed, peg, offset) for world in worlds]
            out.append([TransferResult(p, None if p else "lift", 4.0) for p in placed])
        return out

    return mapper


REAL = Outcomes(
    tuple(failing_at("lift", v, c, 120, 60 if c == "uncalibrated" else 120) for v, c in CELLS), "test"
)


def test_an_offset_luckiest_on_the_fits_seeds_is_not_named_where_a_bending_peg_fits_on_fresh_ones():
    # ranked on the fit's own seeds the offset came first, the peg was only tried on top of it, and
    # nothing was named
    d = diagnose(REAL, SETTINGS, _mapper(peg=0.5, offset=0.1))
    assert {"peg_compliance.deflection", "registration_offset.x"} <= set(d.verdict.passing)
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"]
    assert d.verdict.tied == ()


def test_an_offset_alone_in_passing_is_chosen_refused_on_fresh_seeds_and_reported_so():
    d = diagnose(REAL, SETTINGS, _mapper(peg=0.05, offset=0.05))
    assert d.verdict.named == () and d.verdict.tied == ()
    assert {"registration_offset.x", "registration_offset.y"} & set(d.unreplicated)
    assert set(report_dict(d)["unreplicated"]) == set(d.unreplicated)
    assert "registration_offset" in report_markdown(d)
