"""Test-wide settings: where the real dVRK recordings live, how tests run the `pegbt` command, and that no
test leaves its process in a real-time scheduling class (everything it started later would inherit it)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from schedule_helpers import LONGEST_S

from pegbt.errors import PegbtError
from pegbt.physics.recording import dvrk_data_dir

REPO = Path(__file__).resolve().parents[1]


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Longest first: the modules `LONGEST_S` times, longest first, then those holding a `slow` test (the
    system tier's first), then the rest of the system tier, then the others, each module in one piece and in
    its own order. `--dist loadfile` (pyproject) hands a free worker the next module in this order: the
    suite's wall is the last worker's, and a long module started last keeps one busy while the others idle."""
    rank: dict[Path, tuple[int, int]] = {}
    for item in items:
        system = item.get_closest_marker("system") is not None
        own = (0 if system else 1) if item.get_closest_marker("slow") else 2 if system else 3
        longest = -LONGEST_S.get(item.path.relative_to(REPO).as_posix(), 0)
        rank[item.path] = min(rank.get(item.path, (0, 3)), (longest, own))
    items.sort(key=lambda item: rank[item.path])


@pytest.fixture(autouse=True)
def ordinary_scheduling() -> Iterator[None]:
    """A test that leaves the worker in SCHED_FIFO fails: every simulator or run the worker starts after it
    would inherit the priority, and one that spins starves the machine."""
    policy = os.sched_getscheduler(0)
    yield
    left = os.sched_getscheduler(0)
    if left != policy:
        os.sched_setscheduler(0, policy, os.sched_param(0))
        pytest.fail(f"the test left its process in scheduling policy {left} (was {policy})")


@pytest.fixture
def dvrk_data() -> Path:
    """The folder of real dVRK recordings; tests that need it skip, saying why, when it is absent."""
    try:
        return dvrk_data_dir(required=True)
    except PegbtError as missing:
        pytest.skip(str(missing))


class PegbtCommand:
    """`python -m pegbt ARGS` in a child process, as a user runs it: from the repository root (or `cwd`),
    this checkout first on PYTHONPATH. For what only a real process shows: the exit status, no traceback,
    a signal; everything else calls `pegbt.cli.main` in the test's process (no 3-4 s of imports)."""

    def __init__(self) -> None:
        path = os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))
        self.env = {**os.environ, "PYTHONPATH": path}

    def __call__(
        self, *args: object, cwd: Path | None = None, timeout: float = 120
    ) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            self._argv(args), capture_output=True, text=True, cwd=cwd or REPO, env=self.env, timeout=timeout
        )

    def start(self, *args: object, cwd: Path | None = None) -> subprocess.Popen[str]:
        """The command running, its output piped (to signal it before it ends). Ctrl-C reaches it even when the
        suite itself runs where SIGINT is ignored (a background job), which the child would inherit."""
        return subprocess.Popen(
            self._argv(args),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=cwd or REPO,
            env=self.env,
            preexec_fn=_interruptible,
        )

    @staticmethod
    def _argv(args: tuple[object, ...]) -> list[str]:
        return [sys.executable, "-m", "pegbt", *map(str, args)]


def _interruptible() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.fixture(scope="session")
def pegbt_cli() -> PegbtCommand:
    """Runs `python -m pegbt` in a child process; see `PegbtCommand`."""
    return PegbtCommand()


@pytest.fixture
def short_connect_waits(monkeypatch: pytest.MonkeyPatch) -> None:
    """A connection that finds nobody, or not all a robot should send, gives up after 1 s instead of the 2 s
    probe and the 5 s per topic a loaded robot or simulator is allowed: what the error says does not depend
    on how long (what does come, a double's joints at its rate, comes well within 1 s)."""
    from pegbt.behaviours.resources import robot

    monkeypatch.setattr(robot, "PROBE_TIMEOUT", 1.0)
    monkeypatch.setattr(robot, "READY_TIMEOUT", 1.0)
