"""The system tier: whole trials, real time, a browser, Dask, ROS 2, real recordings, and whole sim-to-real
diagnoses (a cross-validated search of a synthetic recording: tens of seconds of CPU each, half the in-process
tests' time). Every test here carries the `system` marker, so `pytest -m "not system"` is the fast loop and
the whole suite still runs them all."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from rmw_zenoh_helpers import write_messages, zenoh_router

SYSTEM = Path(__file__).resolve().parent


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Marks every test under this folder `system` before `-m` deselects by marker."""
    for item in items:
        if SYSTEM in item.path.parents:
            item.add_marker(pytest.mark.system)


@pytest.fixture
def messages_dir(tmp_path: Path) -> Path:
    """The ROS 2 message definitions the rmw_zenoh partner node reads."""
    return write_messages(tmp_path)


@pytest.fixture
def router() -> Iterator[int]:
    """The port of a zenoh router on 127.0.0.1 standing in for rmw_zenohd."""
    with zenoh_router() as port:
        yield port
