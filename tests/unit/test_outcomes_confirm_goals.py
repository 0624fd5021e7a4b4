"""Whole trials in a fitted world, judged against the issue's goals cell by cell: ≥ 98 % placed where the
real robot placed every transfer, the real rate's interval and mean transfer time (± 20 %) elsewhere; the
paper's counting, which skips a way back whose block was lost on the way out; and the time of the
transfers placed at their first try, the only ones the paper's robot made."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from executive_helpers import write_tree
from fake_arm import fake_robot

from pegbt.behaviours.resources.skills import Skills
from pegbt.clock import ManualClock
from pegbt.evaluation.trial import TrialRecord
from pegbt.executive.context import RunContext
from pegbt.executive.loader import load_tree
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import retried
from pegbt.executive.runner import run
from pegbt.executive.ticklog import TickLogWriter
from pegbt.executive.work import WorkPool
from pegbt.sim2real.outcomes import confirm as confirm_module
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.confirm import confirm, first_tries, ways_back_skipped
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.goals import Trials, judge, verdict_text
from pegbt.sim2real.outcomes.phasesim import TransferResult
from pegbt.sim2real.outcomes.report import write_report
from pegbt.sim2real.outcomes.simulate import Task

UNCAL = Cell("unilateral", "uncalibrated", 75, 26, mean_transfer_s=5.6)
CAL = Cell("unilateral", "calibrated", 120, 120, mean_transfer_s=5.7)


@pytest.mark.parametrize(
    ("placed", "holds", "below_beyond_chance"),
    [(120, True, False), (118, True, False), (115, False, False), (114, False, True)],
)
def test_a_cell_placed_in_full_keeps_98_percent_by_its_point_rate(
    placed: int, holds: bool, below_beyond_chance: bool
) -> None:
    verdict = judge(CAL, Trials(120, placed, 2.7, 10, 0))
    assert verdict["rate_holds"] is holds and verdict["holds"] is holds
    assert verdict["below_beyond_chance"] is below_beyond_chance
    assert verdict["shown"] is False  # 120 transfers cannot show 98 % beyond chance
    assert verdict["time_judged"] is False and verdict["time_holds"] is None  # pegbt's own planner


def test_189_transfers_none_failed_show_98_percent() -> None:
    verdict = judge(CAL, Trials(189, 189, 2.7, 16, 0))
    assert verdict["shown"] is True
    assert verdict_text(verdict) == "holds, shown beyond chance"


def test_an_uncalibrated_cell_needs_its_rate_in_the_real_interval_and_its_time_within_20_percent() -> None:
    inside = judge(UNCAL, Trials(80, 28, 6.4, 10, 0))  # 35 %, 6.4 s: +14 %
    assert inside["rate_holds"] and inside["time_holds"] and inside["holds"]
    assert verdict_text(inside).startswith("rate in real 24.0 %–46.5 %")
    assert verdict_text(inside).endswith("time +14 %, within 20 %")
    slow = judge(UNCAL, Trials(80, 28, 7.0, 10, 0, first_tries=20, first_try_mean_transfer_s=5.32))
    assert slow["rate_holds"] and slow["time_holds"] is False and not slow["holds"]  # +25 %
    assert slow["first_try_ratio"] == pytest.approx(0.95)
    assert verdict_text(slow).endswith("time +25 %, **not within** 20 % (its 20 first tries -5 %)")
    low = judge(UNCAL, Trials(120, 6, 5.6, 10, 0))  # 5 %, the simulator's old uncalibrated rate
    assert not low["rate_holds"] and not low["holds"] and low["p_value"] < 1e-6
    assert "**not in**" in verdict_text(low)
    nothing = judge(UNCAL, Trials(120, 0, None, 10, 0))
    assert nothing["time_holds"] is None and verdict_text(nothing).endswith(
        "time not judged (nothing placed)"
    )


def _transfer(index: int, pick: int, place: int, succeeded: bool) -> dict[str, object]:
    return {"index": index, "pick": pick, "place": place, "succeeded": succeeded}


def test_the_paper_skips_a_way_back_whose_block_was_lost_on_the_way_out() -> None:
    trial = [
        _transfer(0, 0, 6, True),
        _transfer(1, 1, 7, False),  # lost: peg 7 stays empty
        _transfer(2, 6, 0, True),
        _transfer(3, 7, 1, False),  # never attempted by the paper's robot
    ]
    assert ways_back_skipped(trial, "unilateral") == {3}
    found = [*trial[:3], _transfer(3, 7, 1, True)]  # placed after all: its block was there
    assert ways_back_skipped(found, "unilateral") == set()


def test_in_bilateral_the_paper_skips_both_transfers_of_a_pair_whose_one_block_was_lost() -> None:
    """`FLSPegTransfer_dual.py` moves an action pair only when it finds both blocks: PSM2's 0 -> 7 lost, the
    way back 7 -> 0 is skipped and so is PSM1's 8 -> 1, its pair, though the trial's PSM1 placed it."""
    trial = [
        _transfer(0, 0, 7, False),
        _transfer(1, 1, 8, True),
        _transfer(2, 7, 0, False),
        _transfer(3, 8, 1, True),
    ]
    assert ways_back_skipped(trial, "bilateral") == {2, 3}
    assert ways_back_skipped(trial, "unilateral") == {2}  # one block at a time: its own block alone
    both = [*trial[:1], _transfer(1, 1, 8, False), *trial[2:3], _transfer(3, 8, 1, False)]
    assert ways_back_skipped(both, "bilateral") == {2, 3}
    kept = [_transfer(0, 0, 7, True), *trial[1:2], _transfer(2, 7, 0, False), trial[3]]
    assert ways_back_skipped(kept, "bilateral") == set()  # both found: the pair moves, 7 -> 0 fails


def test_whole_bilateral_trials_count_neither_transfer_of_a_pair_the_paper_skipped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`confirm` under the paper's counting: a trial whose PSM2 lost 0 -> 7 attempted 4 transfers and placed
    2 (1 -> 8, then 8 -> 1, which the paper's robot would have skipped with its pair); counted so, it
    attempted 2 and placed 1, timed by 1 -> 8 alone (3 s, where the trial's two placed took 4 s a transfer).
    An errored trial counts nothing."""
    timed = {0: (0.0, None), 1: (0.0, 3.0), 2: (10.0, None), 3: (10.0, 5.0)}
    trial = [
        {**t, "started": timed[t["index"]][0], "seconds": timed[t["index"]][1]}
        for t in (
            _transfer(0, 0, 7, False),
            _transfer(1, 1, 8, True),
            _transfer(2, 7, 0, False),
            _transfer(3, 8, 1, True),
        )
    ]
    records = [
        SimpleNamespace(outcome="ok", transfers=trial),
        SimpleNamespace(outcome="error", transfers=trial),
    ]

    def summary(campaign, ran, workers) -> dict[str, object]:
        kept = [t for r in ran if r.outcome != "error" for t in r.transfers]
        placed = sum(bool(t["succeeded"]) for t in kept)
        return {
            "transfers_attempted": len(kept),
            "transfers_succeeded": placed,
            "mean_transfer_time_s": 4.0,
            "errors": len(ran) - 1,
        }

    monkeypatch.setattr(confirm_module, "run_trials", lambda specs, workers: records)
    monkeypatch.setattr(confirm_module, "summarise", summary)
    cell = Cell("bilateral", "calibrated", 120, 120)
    world = tmp_path / "world.yaml"
    world.write_text("effects: []\n")
    (figures,) = confirm(world, [cell], 2, tmp_path, 1, until_lost=True, protocol="paper").values()
    assert (figures.attempted, figures.succeeded, figures.skipped, figures.errors) == (2, 1, 2, 1)
    assert figures.mean_transfer_s == pytest.approx(3.0)


def _mapper(tasks: Sequence[Task]) -> list[list[TransferResult]]:
    """A bending peg raises the uncalibrated lift's success; a calibrated arm always places."""
    out = []
    for worlds, _variant, condition, seed in tasks:
        u = np.random.default_rng([seed, 3]).random()
        rates = [
            1.0
            if condition != "uncalibrated"
            else 0.05 + 0.4 * w.values("peg_compliance")["deflection"] / 0.003
            for w in worlds
        ]
        out.append([TransferResult(bool(u < r), None if u < r else "lift", 5.0) for r in rates])
    return out


def test_the_report_carries_each_confirmed_cells_counts_interval_and_verdict(tmp_path: Path) -> None:
    outcomes = Outcomes((UNCAL, CAL), "test", attempts_end_at_lost_block=True)
    d = diagnose(outcomes, Settings(fit="all", transfers=60, points=3), _mapper)
    confirmed = {
        "world.yaml": {
            UNCAL.key: Trials(90, 30, 8.0, 10, 0, skipped=30),
            CAL.key: Trials(120, 117, 2.7, 10, 1),
        }
    }
    data = write_report(d, tmp_path, ["pegbt sim2real outcomes"], confirmed)
    cells = {c["condition"]: c["confirmed"]["world.yaml"] for c in data["cells"]}
    assert cells["calibrated"]["goal"] == "placed >= 98 %"
    assert cells["calibrated"]["rate"] == pytest.approx(117 / 120)
    assert cells["calibrated"]["holds"] is False and cells["calibrated"]["errors"] == 1
    assert cells["uncalibrated"]["rate_holds"] is True and cells["uncalibrated"]["time_holds"] is False
    assert cells["uncalibrated"]["skipped"] == 30
    assert (
        json.loads((tmp_path / "report.json").read_text())["cells"][1]["confirmed"]["world.yaml"]["holds"]
        is False
    )
    markdown = (tmp_path / "report.md").read_text()
    assert "a way back whose block was lost on the way out is skipped" in markdown
    assert (
        "| world.yaml | unilateral | calibrated | 117/120 (97.5 %; 92.9 %–99.1 %) | 120/120 | 2.70 / 5.7 s "
        "| **fails** (within chance) | 1 of 10 |"
    ) in markdown
    assert "| world.yaml | unilateral | uncalibrated | 30/90 (33.3 %; " in markdown
    assert "At world.yaml: the goals hold in 0 of 2 cells." in markdown


TWO_TRANSFERS = """
tree:
  sequence:
    name: task
    children:
      - sequence:
          name: first
          children:
            - begin_transfer: {name: begin, arms: PSM1, pick: 0, place: 6, transfer: /PSM1/transfer}
            - recover:
                name: pick and carry, recovering
                retries: 2
                main: {scripted: {name: pick, outcomes: [failure, success], message: missed}}
                recovery: {scripted: {name: look again, outcomes: [success]}}
            - finish_transfer: {name: placed, outcome: placed, transfer: /PSM1/transfer}
      - sequence:
          name: second
          children:
            - begin_transfer: {name: begin, arms: PSM1, pick: 1, place: 7, transfer: /PSM1/transfer}
            - recover:
                name: pick and carry, recovering
                retries: 2
                main: {scripted: {name: pick, outcomes: [success]}}
                recovery: {scripted: {name: look again, outcomes: [success]}}
            - finish_transfer: {name: placed, outcome: placed, transfer: /PSM1/transfer}
"""


RETAKE_AND_RELOOK = """
tree:
  sequence:
    name: task
    children:
      - sequence:
          name: taken on the second try
          children:
            - begin_transfer: {name: begin, arms: PSM2→PSM1, pick: 0, place: 6, transfer: /handover/transfer_1}
            - retry:
                name: tries
                attempts: 5
                child: {scripted: {name: one try, outcomes: [failure, success], message: missed the block at the handover}}
            - finish_transfer: {name: placed, outcome: placed, transfer: /handover/transfer_1}
      - sequence:
          name: looked at twice
          children:
            - begin_transfer: {name: begin, arms: PSM1, pick: 1, place: 7, transfer: /PSM1/transfer}
            - retry:
                name: until a usable capture
                attempts: 3
                child: {scripted: {name: look, outcomes: [failure, success], message: poor capture}}
            - retry:
                name: one take
                attempts: 1
                child: {scripted: {name: take, outcomes: [success]}}
            - finish_transfer: {name: placed, outcome: placed, transfer: /PSM1/transfer}
"""


def _logged(tmp_path: Path, tree: str) -> Path:
    """`tree` run on the in-memory robot to its end; its tick log."""
    clock = ManualClock()
    skills = Skills("uncalibrated")
    robot = fake_robot(clock, skills.settings, skills.cell)
    context = RunContext(
        clock=clock, resources={"robot": robot, "skills": skills}, work=WorkPool(inline=True)
    )
    built = load_tree(write_tree(tmp_path, tree)).build(context)
    log = tmp_path / "run.jsonl"
    run(built, period=0.1, timeout=10.0, log=TickLogWriter(log, built, clock_kind="manual"))
    return log


def test_a_block_a_receiver_took_on_its_second_try_was_retried_and_a_second_look_was_not(
    tmp_path: Path,
) -> None:
    """A handover's receiver that missed and took the block again (`receive`'s retry of `try_to_take`) tried
    the transfer again; a capture taken again (`sense`'s retry) did not. A real trial's log:
    `tests/system/test_handover_takes_policy.py`."""
    assert retried(read_tick_log(_logged(tmp_path, RETAKE_AND_RELOOK))) == {1}


def test_a_transfer_tried_again_is_not_timed_as_a_first_try(tmp_path: Path) -> None:
    log = _logged(tmp_path, TWO_TRANSFERS)
    assert retried(read_tick_log(log)) == {1}
    transfers = [
        {"index": 1, "succeeded": True, "started": 0.0, "seconds": 12.0},
        {"index": 2, "succeeded": True, "started": 12.0, "seconds": 5.0},
        {"index": 3, "succeeded": False, "started": 17.0, "seconds": None},
        {"index": 4, "succeeded": True, "started": 13.0, "seconds": 5.0},  # the other arm, at once
    ]
    record = TrialRecord("unilateral", "uncalibrated", 7000, "failure", log=str(log), transfers=transfers)
    errored = TrialRecord("unilateral", "uncalibrated", 7001, "error")
    assert first_tries([record, errored]) == (2, 3.0)  # 12-18 s busy, shared by two placed at once
