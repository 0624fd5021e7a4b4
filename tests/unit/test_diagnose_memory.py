"""A diagnosis's stages hold no recording-sized array of their own: the nested cross-validation's
training parts, drivers and held-out predictions are in scratch files (`pegbt.scratch`), and
`locate` keeps its motion regimes as masks.

As in `test_sim2real_memory.py`, each memory test measures the peak of traced memory at two lengths:
what grows with the recording is the difference. A (N, 6) array of floats is 48 bytes a sample."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from memory_helpers import peak_bytes
from sim2real_helpers import recording_with

from pegbt.physics import ArmPhysics, Effect
from pegbt.scratch import scratch, scratch_rows
from pegbt.sim2real import diagnose
from pegbt.sim2real import locate as locate_module
from pegbt.sim2real.crossval import BlockedGrams
from pegbt.sim2real.diagnose import nested_predict, rms, static_drivers
from pegbt.sim2real.locate import locate
from pegbt.sim2real.select import JointSelection

ROW = 6 * 8  # bytes of one sample of (N, 6) floats


def test_scratch_rows_are_the_masked_rows_and_not_traced() -> None:
    values = np.random.default_rng(0).normal(size=(10_000, 6))
    keep = np.ones(len(values), dtype=bool)
    keep[2_000:4_000] = False
    peak, copy = peak_bytes(lambda: scratch_rows(values, (2_000, 4_000)))
    np.testing.assert_array_equal(copy, values[keep])
    assert peak < 0.1 * values[keep].nbytes
    assert scratch((0, 6)).shape == (0, 6)


def test_drivers_and_rms_in_scratch_are_the_same_numbers() -> None:
    q_cmd = np.random.default_rng(1).normal(size=(20_000, 6))
    base = ArmPhysics(
        [Effect("coupling", "q2", {"source": "q1", "k": 0.1}), Effect("scale", "q3", {"value": 0.02})]
    )
    np.testing.assert_array_equal(static_drivers(base, q_cmd), base.static_map(q_cmd))
    np.testing.assert_array_equal(rms(q_cmd), np.sqrt((q_cmd**2).mean(0)))


def _locate_peak(n: int) -> int:
    rng = np.random.default_rng(0)
    q_cmd = 0.01 * np.cumsum(rng.normal(size=(n, 6)), axis=0)
    residual = 0.01 * rng.normal(size=(n, 6))
    t = 0.01 * np.arange(n)
    return peak_bytes(lambda: locate(residual, q_cmd, t, True))[0]


def test_locate_keeps_masks_not_float_arrays_of_the_motion() -> None:
    _locate_peak(500)
    growth = (_locate_peak(40_000) - _locate_peak(10_000)) / 30_000
    # four masks (24 bytes a sample) and one joint's moving mean square; it was 324 bytes a sample
    # (directions, speeds, steps and the other joints' motion as (N, 6) floats), then 148 with the
    # play path, moves, speeds and the regimes' residuals of one joint at a time in memory
    assert growth < ROW


def test_locate_a_few_rows_at_a_time_finds_what_it_finds_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    effects = [
        Effect("backlash", "q6", {"half_width": 0.04}),
        Effect("coupling", "q5", {"source": "q4", "k": 0.2}),
    ]
    recording = recording_with(effects, seconds=60.0)
    residual = recording.q_phy - ArmPhysics().simulate(recording.q_cmd, recording.t)
    whole = [m.to_dict() for m in locate(residual, recording.q_cmd, recording.t, True)]
    assert any(m["regimes"] for m in whole)  # the chunks below cut through reversals and their holds
    monkeypatch.setattr(locate_module, "ROWS", 97)
    assert [m.to_dict() for m in locate(residual, recording.q_cmd, recording.t, True)] == whole


def _held_at_selection(monkeypatch: pytest.MonkeyPatch, seconds: float) -> tuple[int, int]:
    """Traced bytes held when a nested segment's selection starts (the selection itself stubbed: it
    names nothing), above what was held before `nested_predict`, and the recording's length."""
    recording = recording_with([], seconds=seconds)
    residual = recording.q_phy - ArmPhysics().simulate(recording.q_cmd, recording.t)
    n = recording.n
    held: list[int] = []

    def names_nothing(grams: BlockedGrams, *_: object) -> tuple[list[JointSelection], int]:
        held.append(tracemalloc.get_traced_memory()[0])
        return [JointSelection(j) for j in range(grams.targets.shape[1])], 1

    monkeypatch.setattr(diagnose, "select", names_nothing)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        segment = [(int(0.4 * n), int(0.6 * n))]  # a middle one: its training part is two pieces
        nested_predict(recording, recording.t, residual, ArmPhysics(), None, segment)
    finally:
        tracemalloc.stop()
    return max(held) - before, n


def test_a_nested_segment_holds_no_training_copy_drivers_nor_predictions(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    short, n_short = _held_at_selection(monkeypatch, 20.0)
    long, n_long = _held_at_selection(monkeypatch, 60.0)
    # it was 4.8 ROW: the training part's commands, times and residual, its drivers and the two
    # held-out predictions, all in memory
    assert (long - short) / (n_long - n_short) < 0.25 * ROW
