"""Test-wide settings: one torch thread (2-core machines), and where the real dVRK recordings live."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

DVRK_DATA = Path(os.environ.get("PEGBT_DVRK_DATA", Path(__file__).resolve().parents[2] / "shared" / "data" / "dvrk"))


@pytest.fixture
def dvrk_data() -> Path:
    """The folder of real dVRK recordings; tests that need it skip, saying why, when it is absent."""
    if not (DVRK_DATA / "random_smooth_grey1_PSM1" / "q_cmd.npy").exists():
        pytest.skip(f"real dVRK recordings not found at {DVRK_DATA} (set PEGBT_DVRK_DATA)")
    return DVRK_DATA
