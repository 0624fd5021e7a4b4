"""`pegbt bench sim2real-outcomes` runs every diagnosis of every family and seed through one memo of
simulated transfers; its figures must be those of diagnoses that each simulate everything afresh."""

from __future__ import annotations

import math
import statistics

from pegbt.bench import sim2real_outcomes as bench
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.diagnose import diagnose
from tests.outcomes_helpers import fake_mapper

FAMILIES = ["peg_compliance", "null"]
SEEDS = 2
REAL = 40


def _same(a: float | int | str, b: float | int | str) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_the_shared_memo_gives_the_figures_of_unshared_diagnoses() -> None:
    figures = bench.measure(FAMILIES, SEEDS, REAL, bench.SETTINGS, simulator=fake_mapper)
    scores: dict[str, list[dict[str, float]]] = {family: [] for family in FAMILIES}
    needed = 0
    for seed in range(SEEDS):
        for family in FAMILIES:
            world = WorldEffects.of(bench.FAMILIES[family])
            size = figures[f"{family}_real_transfers_per_fit_cell"]
            assert isinstance(size, int)
            (real,) = bench.concealed_outcomes(fake_mapper, [world], seed, size, REAL)
            alone = diagnose(real, bench.SETTINGS, fake_mapper)
            needed += alone.simulated
            scores[family].append(bench.score(alone, bench.FAMILIES[family]))
    for family in FAMILIES:
        for name in ("false", "inside") if family == "null" else ("named", "false", "inside"):
            assert _same(figures[f"{family}_{name}"], statistics.mean(s[name] for s in scores[family]))
    # the peg named on some seed, nothing on the null: the figures compared are not all empty
    assert figures["peg_compliance_named"] > 0 and figures["null_false"] == 0.0  # type: ignore[operator]
    assert figures["null_named"] == "n/a"
    errors = [s["error"] for s in scores["peg_compliance"] if not math.isnan(s["error"])]  # where named
    assert figures["peg_compliance_parameter_error_median"] == statistics.median(errors)
    assert figures["transfers_the_diagnoses_simulate"] == needed
    # what the benchmark asks besides the diagnoses: each seed's concealed cells in every family's world, and
    # the detectability's default and concealed worlds on the located seeds of the fit cells
    fit_cells = sum(bench.SETTINGS.fit in ("all", v, c) for v, c in bench.CELLS)
    sizes = [figures[f"{family}_real_transfers_per_fit_cell"] for family in FAMILIES]
    concealed = SEEDS * sum(fit_cells * n + (len(bench.CELLS) - fit_cells) * REAL for n in sizes)  # type: ignore[operator]
    located = len(FAMILIES) * fit_cells * bench.SETTINGS.located
    asked = needed + concealed + located
    assert isinstance(figures["transfers_simulated"], int) and figures["transfers_simulated"] < asked
