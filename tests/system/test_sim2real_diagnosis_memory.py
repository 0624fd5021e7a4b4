"""A whole diagnosis's memory per sample of recording: what grows with the length is a few whole arrays
(the recording, its replays, each held-out segment's training copy), never a bank of columns held together.
A system test: two diagnoses under tracemalloc take about half a minute on a quiet core."""

from __future__ import annotations

import pytest
from memory_helpers import peak_bytes

from pegbt.sim2real import crossval, geometry
from pegbt.sim2real.diagnose import diagnose
from pegbt.sim2real.synth import generate

pytestmark = pytest.mark.system

SHORT_S, LONG_S = 30.0, 60.0
CHUNK = 300  # rows: a whole diagnosis in smaller chunks takes minutes
GROWTH_BYTES_PER_SAMPLE = 210  # measured 189; 231 with the refined width columns held together


def _diagnosis_peak(seconds: float) -> tuple[int, int]:
    """(samples, peak traced bytes) of diagnosing a synthetic recording of `seconds` at 100 Hz."""
    recording = generate("weak", 0, seconds).recording
    peak, _ = peak_bytes(lambda: diagnose(recording, n_bootstrap=0))
    return recording.n, peak


def test_a_diagnosis_holds_no_more_than_a_few_whole_arrays(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(crossval, "CHUNK_ROWS", CHUNK)
    monkeypatch.setattr(geometry, "CHUNK_ROWS", CHUNK)
    _diagnosis_peak(5)  # imports and caches
    n_short, short = _diagnosis_peak(SHORT_S)
    n_long, long = _diagnosis_peak(LONG_S)
    assert (long - short) / (n_long - n_short) < GROWTH_BYTES_PER_SAMPLE
