"""The report's verdict on the held-out cells names the world it judges: the fitted world alone, each world
the fit cells cannot tell from it, and which cells only such a world reaches (the paper's bilateral row,
reached by a chamfer or a grasp capture on top of the bending peg, never by the peg alone)."""

from __future__ import annotations

from pathlib import Path

from pegbt.sim.world_effects import WorldEffects, read_world_file
from pegbt.sim2real.outcomes.cells import Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.report import report_dict, report_markdown, write_report
from pegbt.sim2real.outcomes.simulate import Mapper
from tests.outcomes_helpers import failing_at, rate_mapper


def _rate(effects: WorldEffects, variant: str, condition: str) -> float:
    """A bending peg raises every uncalibrated cell; a grasp capture only bilateral's (the other arm)."""
    if condition != "uncalibrated":
        return 1.0
    bend = effects.values("peg_compliance")["deflection"] / 0.003
    capture = effects.values("grasp_capture")["width"] / 0.003
    return 0.05 + 0.4 * bend + (0.6 * capture if variant == "bilateral" else 0.0)


_mapper = rate_mapper(_rate, "lift", stream=11)


CELLS = (
    failing_at("lift", "unilateral", "uncalibrated", 80, 28),
    failing_at("lift", "unilateral", "calibrated", 80, 80),
    failing_at("lift", "bilateral", "uncalibrated", 80, 46),
    failing_at("lift", "bilateral", "calibrated", 80, 80),
)


def test_a_held_out_cell_only_an_alternative_reaches_is_said_so_and_not_counted_for_the_fitted_world() -> (
    None
):
    mapper: Mapper = _mapper
    d = diagnose(Outcomes(CELLS, "test"), Settings(fit="unilateral", transfers=120, points=3), mapper)
    assert [p.candidate.kind for p in d.verdict.named] == ["peg_compliance"]
    assert "grasp_capture.width" in {a.name for a in d.alternatives}
    report = report_dict(d)
    bilateral = next(c for c in report["cells"] if c["variant"] == "bilateral")
    assert not bilateral["rate_in_real_interval"]  # the fitted world alone
    assert bilateral["predicted_by"]["grasp_capture.width over 0–0.003"]["rate_in_real_interval"]
    markdown = report_markdown(d)
    assert "With peg_compliance (the prediction above): " in markdown
    assert (
        "of the 1 the real robot did not place in full, the predicted rate inside the real count's 95 % interval in 0."
        in markdown
    )
    assert (
        "- bilateral uncalibrated: the predicted rate reaches the real count's 95 % interval only with "
        "grasp_capture.width over 0–0.003" in markdown
    )
    assert "with peg_compliance it does not" in markdown
    assert "| grasp_capture.width over 0–0.003 | " in markdown
    assert "2 held-out cells inside" in markdown
    assert "| 189/189 placed |" in markdown  # a cell placed in full is judged by what it keeps
    # over an open effect's range there is no best value to keep: the full cell gets its predicted rate
    row = next(
        line for line in markdown.splitlines() if line.startswith("| grasp_capture.width over 0–0.003 |")
    )
    assert "placed" not in row and row.count("inside") == 2


def test_each_open_alternative_is_written_as_a_world_a_campaign_can_run(tmp_path: Path) -> None:
    d = diagnose(Outcomes(CELLS, "test"), Settings(fit="unilateral", transfers=120, points=3), _mapper)
    data = write_report(d, tmp_path)
    path = tmp_path / "world-open-grasp_capture.width.yaml"
    assert str(path) in data["open_world_files"] and str(path) not in data["world_files"]
    world = read_world_file(path)
    assert world.values("grasp_capture")["width"] == 0.003  # the alternative, on top of the fitted peg
    assert world.values("peg_compliance")["deflection"] > 0  # the peg the prediction bent, kept
