"""A page that sends `pegbt run --monitor` a 400 MB frame is cut off at the frame's header: the process's
peak memory barely moves and the run goes on to its end (before, the frame was read whole: 1.7 GB)."""

from __future__ import annotations

import pytest

from pegbt.bench.monitor_limits import huge_frame_growth


@pytest.mark.slow
def test_a_400_mb_frame_is_refused_at_its_header_and_the_run_goes_on(tmp_path):
    growth, outcome = huge_frame_growth(tmp_path, seconds=2.0)
    assert growth < 50 * 2**20, f"VmHWM grew {growth / 2**20:.0f} MB"
    assert outcome == "timeout"  # it ticked until its --timeout, as it would have without the frame
