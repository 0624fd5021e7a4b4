"""Test-wide settings: one torch thread (2-core machines), and where the real dVRK recordings live."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.physics.recording import dvrk_data_dir


@pytest.fixture
def dvrk_data() -> Path:
    """The folder of real dVRK recordings; tests that need it skip, saying why, when it is absent."""
    try:
        return dvrk_data_dir(required=True)
    except PegbtError as missing:
        pytest.skip(str(missing))
