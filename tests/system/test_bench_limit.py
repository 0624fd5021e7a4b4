"""`pegbt bench limit` on real lockstep trials: the bound is never above what pegbt achieves, and the
breakdown accounts for the whole difference."""

from __future__ import annotations

from pathlib import Path

import pytest
from trial_helpers import one_handover, short_task

from pegbt.bench.limit import PARTS, breakdown, transfers_of
from pegbt.bench.limit_bound import Bound, Heights, trial_bound
from pegbt.evaluation.trial import TrialSpec, run_trial

pytestmark = pytest.mark.system


@pytest.mark.parametrize("tree", [short_task, one_handover], ids=["one transfer", "one handover"])
def test_bound_is_below_a_lockstep_trial_and_the_parts_add_up(tmp_path: Path, tree) -> None:  # noqa: ANN001
    spec = TrialSpec(
        "unilateral", "optimized", 1000, tmp_path / "trial.jsonl", keep_log=True, tree=tree(tmp_path)
    )
    record = run_trial(spec)
    assert record.complete, record.error or record.transfers
    bound = Bound()
    floor = trial_bound(transfers_of(record), bound).per_transfer_s
    assert record.mean_transfer_time_s is not None
    assert 0 < floor <= record.mean_transfer_time_s
    parts = breakdown([record], bound, Bound(Heights.pegbt(bound.motion)))
    assert parts["achieved"] == pytest.approx(record.mean_transfer_time_s)
    assert parts["bound"] + sum(parts[part] for part in PARTS) == pytest.approx(parts["achieved"])
    # the jaw's part may fall below zero: pegbt moves the jaw while the arm moves, the bound does not
    assert parts["waypoints"] >= 0 and parts["path"] > 0
