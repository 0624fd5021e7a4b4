"""The test tiers hold, checked on this run's own collection (whatever part of the suite it is, with its
options): every test collected under `tests/system/` carries the `system` marker, so the fast loop
(`pytest -m "not system"`) leaves out exactly the system tier; and the longest modules run first."""

from __future__ import annotations

from pathlib import Path

from schedule_helpers import LONGEST_S

TESTS = Path(__file__).resolve().parents[1]
SYSTEM = TESTS / "system"


def test_every_system_test_carries_the_system_marker(request) -> None:
    unmarked = [
        item.nodeid
        for item in request.session.items
        if SYSTEM in item.path.parents and not item.get_closest_marker("system")
    ]
    assert not unmarked, unmarked  # under `-m "not system"` such a test would run in the fast loop


def test_the_longest_modules_run_first_then_those_with_a_slow_test_then_the_system_tier_each_in_one_piece(
    request,
) -> None:
    ranks: list[tuple[int, int]] = []
    modules: list[Path] = []
    for item in request.session.items:
        if not modules or modules[-1] != item.path:
            modules.append(item.path)
            ranks.append((-LONGEST_S.get(item.path.relative_to(TESTS.parent).as_posix(), 0), 3))
        system = item.get_closest_marker("system") is not None
        own = (0 if system else 1) if item.get_closest_marker("slow") else 2 if system else 3
        ranks[-1] = (ranks[-1][0], min(ranks[-1][1], own))
    assert len(set(modules)) == len(modules), "a module split in two"
    assert ranks == sorted(ranks), list(zip(ranks, modules, strict=True))
