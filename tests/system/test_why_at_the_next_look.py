"""Under the paper's protocol a receiver opens over its goal peg whatever happened on the way down: the tree
thinks the transfer done, no leaf fails, and only the next look finds the peg without the block. `pegbt log
why` names those failures by that look (lowered, or released above the peg), and the evaluation's check of
`why` against the simulator's ground truth reads them so, instead of counting them as named by nothing."""

from __future__ import annotations

from pathlib import Path

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import TransferCauses, transfer_scopes


def test_a_failure_only_the_next_look_sees_is_named_by_it_and_agrees_with_the_truth(tmp_path: Path) -> None:
    log = tmp_path / "handover.jsonl"
    record = run_trial(TrialSpec("handover", "uncalibrated", 7000, log, keep_log=True, protocol="paper"))
    parsed = read_tick_log(log)
    causes, scopes = TransferCauses(parsed), transfer_scopes(parsed)
    by_look = [
        check
        for check in record.why
        if check["transfer"] and causes.first_cause(scopes.get(check["transfer"], [])) is None
    ]
    assert len(by_look) >= 2  # seed 7000: its first two receivers strike peg 7 and drop the block off peg 6
    for check in by_look:
        assert check["named_phase"] in ("lower", "release")
        assert check["named"].startswith(f"peg {record.transfers[check['transfer'] - 1]['place']} ")
    agreed = [check for check in by_look if check["agrees"]]
    assert len(agreed) >= len(by_look) - 1, by_look  # the truth's phase, up to where a strike ends as a drop
