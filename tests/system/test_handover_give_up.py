"""A giver that cannot pick its block gives the handover up once: it lets go, tells the receiver, and the
trial goes on."""

from __future__ import annotations

from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial


def test_a_giver_that_misses_gives_the_handover_up_once(tmp_path):
    faults = tmp_path / "misses.yaml"
    faults.write_text("world: {miss_probability: 1.0}\n")
    spec = TrialSpec(
        "handover", "optimized", 3, tmp_path / "one-handover.jsonl", faults, tree=one_handover(tmp_path)
    )
    record = run_trial(spec)
    assert record.transfers_attempted == 1  # begun once, not again and again while the jaw opens
    assert [transfer["succeeded"] for transfer in record.transfers] == [False]
    assert (
        record.trial_time_s < 20.0
    )  # the look, one missed pick, letting go: the receiver does not wait it out
