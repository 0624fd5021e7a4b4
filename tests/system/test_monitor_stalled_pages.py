"""Twenty pages that connect to `pegbt run --monitor` and never read cost the run nothing: the server drops
them once their frames pile up, and the run ticks as often, with as few overruns, as with no page at all.
The same figures, with medians over rounds, are `pegbt bench monitor-limits`. Real time: two 5 s runs on the
wall clock, judged by their overruns (the system tier)."""

from __future__ import annotations

from pegbt.bench.monitor_limits import run_with_stalled_pages

SECONDS = 5.0


def test_twenty_pages_that_never_read_are_dropped_and_the_run_ticks_as_without_them(tmp_path):
    alone = run_with_stalled_pages(0, tmp_path, SECONDS)
    overruns, ticks, dropped = run_with_stalled_pages(20, tmp_path, SECONDS)
    assert dropped == 20
    assert overruns <= alone[0] + 2, (alone, (overruns, ticks))  # a loaded machine overruns now and then
    assert ticks >= 0.9 * alone[1], (alone, (overruns, ticks))
