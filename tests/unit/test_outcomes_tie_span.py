"""Effects the outcomes cannot tell apart: the report predicts each held-out cell as the span of rates the
tied effects give, and says whether the real rate's interval holds it."""

from __future__ import annotations

from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.report import report_dict, report_markdown
from tests.outcomes_helpers import rate_mapper

# Uncalibrated unilateral success rises alike with a bending peg and with chamfers; bilateral only with the peg.
GAIN = {"unilateral": (0.6, 0.6), "bilateral": (0.6, 0.0)}


def _rate(effects, variant: str, condition: str) -> float:
    bend = effects.values("peg_compliance")["deflection"] / 0.003
    chamfer = (effects.values("chamfer_capture")["capture_radius"] - 0.002) / 0.002
    peg, cham = GAIN[variant]
    return 1.0 if condition != "uncalibrated" else 0.05 + peg * bend + cham * chamfer


_twin_mapper = rate_mapper(_rate, "lift")


def test_a_tie_predicts_each_held_out_cell_as_the_span_of_its_effects_rates():
    cells = (
        Cell("unilateral", "uncalibrated", 80, 28),
        Cell("unilateral", "calibrated", 80, 80),
        Cell("bilateral", "uncalibrated", 80, 28),
    )
    d = diagnose(Outcomes(cells, "test"), Settings(fit="unilateral", transfers=200, points=5), _twin_mapper)
    assert {t.candidate.kind for t in d.verdict.tied} >= {"peg_compliance", "chamfer_capture"}
    assert all(any(path[-1] is t for path in d.verdict.paths) for t in d.verdict.tied)  # what names one
    assert d.resolved.startswith("The tie stands: on 320 fresh simulated transfers a fit cell")
    assert report_dict(d)["tie"] == d.resolved and d.resolved in report_markdown(d)
    cell = next(c for c in report_dict(d)["cells"] if c["variant"] == "bilateral")
    low, high = cell["predicted_span"]
    assert d.pools_after and cell["simulated_after_pooled"]  # each tied world's best value, pooled
    assert low < 0.15 and 0.25 < high  # chamfers leave bilateral where it was; the peg raises it
    assert "Across the tie" in report_markdown(d) and "bilateral uncalibrated" in report_markdown(d)
