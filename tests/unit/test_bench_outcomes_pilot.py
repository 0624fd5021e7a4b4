"""The benchmark's pilot reads each concealed effect's change from at least as many paired transfers as the
campaign it sizes: a small change in a category of a few per cent, read from 48, is mostly noise."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from pegbt.bench import sim2real_outcomes as bench
from pegbt.bench.outcomes_power import Change, surely_beyond, transfers_to_resolve
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.transfer_result import TransferResult

SMALL = {"depth_bias": {"bias": 0.001}}
LATE = {"jaw_tip_slide": {"width": 0.0008}}
TINY = {"grasp_capture": {"width": 0.0016}}
MIXED = {"grip_compliance": {"displacement": 0.0012}}


def _lifted(world: WorldEffects, seed: int) -> bool:
    """One uncalibrated transfer in 25 fails at the lift in the default world (4 %). Depth bias saves 3 of
    every 8 of them, the first two among them (1.5 points: 2 → 0 of the first 48); jaw tip slide saves
    every other from seed 48 on (2 points, none in the first 48); grasp capture one of every 20 (0.2).
    Grip compliance saves 10 of every 20 and fails 9 of every 20 other transfers: 0.2 points net, 3.8 %
    of the pairs apart."""
    failure = seed // 25
    if seed % 25:
        return not (world.has("grip_compliance") and seed % 25 == 12 and failure % 20 < 9)
    return (
        (world.has("depth_bias") and failure % 8 < 3)
        or (world.has("jaw_tip_slide") and seed >= 48 and failure % 2 == 0)
        or (world.has("grasp_capture") and failure % 20 == 0)
        or (world.has("grip_compliance") and failure % 20 >= 10)
    )


def _mapper(tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]]) -> list[list[TransferResult]]:
    out = []
    for worlds, _, condition, seed in tasks:
        placed = [condition != "uncalibrated" or _lifted(w, seed) for w in worlds]
        out.append([TransferResult(p, None if p else "lift", 4.0) for p in placed])
    return out


def _resolves(change: float) -> int:
    """The real transfers the change needs, its share that of the two worlds' lift failures (4 % and less):
    one 5 % test, since the lift row and the uncalibrated placed row are each alone in their families."""
    s = bench.SETTINGS
    return transfers_to_resolve(change, 0.04 - change / 2, s.real, s.located)


def test_a_small_change_is_sized_from_enough_transfers_not_from_the_first_48() -> None:
    """48 paired transfers show depth bias saving 2 of 2 lift failures (4.2 points), which `detectable_at`
    puts at about 430 real transfers; the change is 1.5 points, which needs about twelve times as many.
    The pilot reads it again until it is read from as many as it asks for, and sizes it within 15 %."""
    s = bench.SETTINGS
    first = bench.shifts(_mapper, {"small": SMALL}, s)["small"]
    assert bench.detectable_at(first, s.real, s.located) < _resolves(0.015) / 5  # the one-shot rule's size
    read = bench.pilot(_mapper, {"small": SMALL}, s)["small"]
    needed = bench.detectable_at(read.changes, s.real, s.located)
    assert needed is not None and needed <= read.transfers
    assert abs(needed - _resolves(0.015)) <= 0.15 * _resolves(0.015)


def test_the_plan_gives_the_size_read_and_what_it_was_read_from(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(bench.FAMILIES, "depth_bias", SMALL)
    p = bench.plan(_mapper, ["depth_bias"], bench.REAL_TRANSFERS, bench.SETTINGS)["depth_bias"]
    assert p.detectable_at is not None and p.detectable_at <= p.read_from
    assert p.size == bench.fit_size([p.detectable_at]) and p.applicable and not p.too_large


def test_a_world_no_transfer_of_its_first_reading_shows_is_read_again_at_the_pilots_largest_size() -> None:
    readings = bench.pilot(_mapper, {"small": SMALL, "late": LATE}, bench.SETTINGS)
    assert readings["late"].transfers == readings["small"].transfers
    assert bench.detectable_at(readings["late"].changes, bench.SETTINGS.real, bench.SETTINGS.located)


def test_a_change_surely_too_large_is_not_read_on_to_the_block(monkeypatch: pytest.MonkeyPatch) -> None:
    """0.2 points of 4 %, every pair that differs differing the same way, needs far more than a seed's
    block of real transfers even at the far end of its interval: the pilot stops there, short of the
    block, and the family keeps the concealed campaign's size, its naming not applicable."""
    monkeypatch.setitem(bench.FAMILIES, "grasp_capture", TINY)
    p = bench.plan(_mapper, ["grasp_capture"], bench.REAL_TRANSFERS, bench.SETTINGS)["grasp_capture"]
    assert p.read_from < bench.SEED_BLOCK / 3 and p.too_large and not p.applicable
    assert p.size == bench.REAL_TRANSFERS


def test_a_change_whose_interval_reaches_under_the_block_is_read_to_the_block(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same 0.2 points net, but with 3.8 % of the pairs apart in both directions: its interval still
    reaches changes the block resolves, so the pilot reads it to the block before calling it too large."""
    monkeypatch.setitem(bench.FAMILIES, "grip_compliance", MIXED)
    p = bench.plan(_mapper, ["grip_compliance"], bench.REAL_TRANSFERS, bench.SETTINGS)["grip_compliance"]
    assert p.read_from == bench.SEED_BLOCK and p.too_large and p.size == bench.REAL_TRANSFERS


def test_a_paired_reading_is_surely_too_large_only_when_few_pairs_differ() -> None:
    """Grasp capture at 1,152: grasp failures 54 → 52. If 4 pairs differ, even the far end of the change's
    interval needs more than a seed's block; if 60 differ (the same net change, far noisier), it may not."""
    s, lift = bench.SETTINGS, Change(False, 0.37, 0.0, 0.02)
    few = [Change(False, 53 / 1152, -2 / 1152, 4 / 1152), lift]
    many = [Change(False, 53 / 1152, -2 / 1152, 60 / 1152), lift]
    assert surely_beyond(few, 1152, bench.SEED_BLOCK, s.real, s.located)
    assert not surely_beyond(many, 1152, bench.SEED_BLOCK, s.real, s.located)
