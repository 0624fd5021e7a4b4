"""A recording read from its folder is mapped from its files, not copied into the process's memory (a
bag's is decoded into scratch files), and checking it (validation, measurement faults, the samples
kept) holds a byte or two a sample: the traced peak at two lengths, as in `test_diagnose_memory.py`;
what grows with the recording is the difference. Reading it held 104 bytes a sample (its commands,
measured joints and times) and checking it about 350 more at once. The checks run a chunk of rows at a
time; chunks of a few rows find what one chunk does."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bag_helpers import setpoint_streams, write_mcap
from memory_helpers import peak_bytes
from scipy.ndimage import median_filter
from sim2real_helpers import bad_recordings, recording_with

from pegbt import scratch
from pegbt.errors import PegbtError
from pegbt.physics import bagfile, faults, plausible, recording
from pegbt.physics.bagfile import read_bag
from pegbt.physics.faults import NEIGHBOURS, Errors, detect_faults
from pegbt.physics.recording import FILES, Recording, load_recording, write_recording
from pegbt.sim2real.synth import with_tracker_faults

ROW = 6 * 8  # bytes of one sample of (N, 6) floats


def _faulty(seconds: float) -> Recording:
    """A 100 Hz stream with tracker glitches and a window where the tracker lost the tool."""
    return with_tracker_faults(recording_with([], seconds=seconds), 40, np.random.default_rng(3))[0]


def _checked_peak(folder: Path) -> tuple[int, int]:
    """(samples, traced peak of reading the folder, finding its faults and keeping the other samples)."""

    def read_and_check() -> Recording:
        read = load_recording(folder)
        return read.subset(detect_faults(read.q_cmd, read.q_phy, read.limits).kept)

    peak, kept = peak_bytes(read_and_check)
    return len(kept), peak


def test_reading_and_checking_a_recording_holds_no_copy_of_it(tmp_path: Path) -> None:
    folders = {}
    for seconds in (300.0, 900.0):  # beyond a few chunks of rows: what a chunk holds no longer grows
        rec = _faulty(seconds)
        folders[seconds] = write_recording(tmp_path / f"r{seconds:g}", rec.q_cmd, rec.q_phy, rec.t)
    n_short, short = _checked_peak(folders[300.0])
    n_long, long = _checked_peak(folders[900.0])
    assert n_long > 2.9 * n_short  # the faults left out are a small share of either
    assert (long - short) / (n_long - n_short) < 0.25 * ROW


@pytest.mark.parametrize("layout", ["<f8", ">f8", "<f4", "fortran"])
def test_arrays_of_any_float_layout_read_as_their_numbers(tmp_path: Path, layout: str) -> None:
    rec = recording_with([], seconds=100.0)  # more rows than a chunk: a cast goes a chunk at a time
    folder = write_recording(tmp_path / layout, rec.q_cmd, rec.q_phy, rec.t)
    as_written = {"q_cmd": rec.q_cmd, "q_phy": rec.q_phy, "t": rec.t}
    for name, values in as_written.items():
        stored = np.asfortranarray(values) if layout == "fortran" else values.astype(layout)
        np.save(folder / FILES[name], stored)
    read = load_recording(folder)
    for name, values in as_written.items():
        expected = values.astype(np.float32) if layout == "<f4" else values
        np.testing.assert_array_equal(getattr(read, name), expected)
        assert getattr(read, name).dtype == np.float64


def _bag_peak(folder: Path, seconds: float) -> tuple[int, int]:
    """(samples, traced peak of reading them) of a 100 Hz stream written as an MCAP bag in chunks of
    16 kB, which the MCAP reader holds one at a time (at its default 1 MB, what it holds grows with a
    bag shorter than a few chunks)."""
    rec = recording_with([], seconds=seconds)
    streams = setpoint_streams(rec.t, rec.q_cmd, rec.q_phy)
    bag = write_mcap(folder / f"b{seconds:g}.mcap", streams, chunk_size=2**14)
    peak, samples = peak_bytes(lambda: read_bag(bag))
    np.testing.assert_array_equal(samples.q_phy, rec.q_phy)
    return len(samples.t), peak


def test_a_bag_is_decoded_into_scratch_not_lists(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for module in (scratch, bagfile):  # chunks of rows fewer than the samples, as in a long bag
        monkeypatch.setattr(module, "ROWS", 256)
    n_short, short = _bag_peak(tmp_path, 10.0)
    n_long, long = _bag_peak(tmp_path, 30.0)
    # it was 965 bytes a sample: each message's stamp and joints as Python floats in a list, per topic
    assert (long - short) / (n_long - n_short) < ROW


def test_faults_found_a_few_rows_at_a_time_are_those_found_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    rec = _faulty(60.0)
    whole = detect_faults(rec.q_cmd, rec.q_phy)
    assert whole.windows and whole.glitches  # the chunks below cut through both
    monkeypatch.setattr(faults, "ROWS", 37)
    chunked = detect_faults(rec.q_cmd, rec.q_phy)
    np.testing.assert_array_equal(chunked.mask, whole.mask)
    assert (chunked.windows, chunked.glitches, chunked.unreachable) == (
        whole.windows,
        whole.glitches,
        whole.unreachable,
    )


def test_running_medians_a_few_rows_at_a_time_are_those_of_the_whole_column() -> None:
    rec = _faulty(10.0)
    errors = Errors.of(rec.q_cmd, rec.q_phy)
    error = rec.q_phy - rec.q_cmd
    whole = np.abs(error - median_filter(error, size=(NEIGHBOURS, 1), mode="nearest")) / errors.spread
    pieces = np.concatenate([errors.local(a, min(a + 37, rec.n)) for a in range(0, rec.n, 37)])
    np.testing.assert_array_equal(pieces, whole)
    np.testing.assert_array_equal(errors.centre, np.median(error, axis=0))


def test_refusals_name_the_same_sample_whatever_the_chunk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for module in (recording, plausible, faults):
        monkeypatch.setattr(module, "ROWS", 5)
    for path, problem in bad_recordings(tmp_path).values():
        with pytest.raises(PegbtError, match=problem):
            load_recording(path)
