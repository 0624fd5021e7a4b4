"""Damaged bags: every failure of the readers is one `PegbtError` line naming the file, and damaged data is
refused or said, never diagnosed as if whole. Bags written by the `mcap` library's writer (CRCs on, as it and
rosbag2's own storage plugin write them), then damaged as a disk or a crash damages them."""

from __future__ import annotations

import contextlib
import io
import random
import struct
from pathlib import Path

import numpy as np
import pytest

from pegbt.bench.fuzz_bags import CMD, PHY, messages_of, write_mcap, write_rosbag2
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.physics.recording import load_recording
from pegbt.sim2real.synth import generate


@pytest.fixture(scope="module")
def messages() -> list[tuple[str, int, bytes]]:
    recording = generate("weak", 0).recording.slice(0, 300)
    return messages_of((1.7e9 + recording.times, recording.q_cmd, recording.q_phy))


def _records(data: bytes) -> list[tuple[int, int, int]]:
    """(opcode, offset of the length field, length) of each top-level record of an MCAP file."""
    records, at = [], 8
    while at + 9 <= len(data):
        length = struct.unpack_from("<Q", data, at + 1)[0]
        records.append((data[at], at + 1, length))
        at += 9 + length
    return records


def _flip_in_first_chunk(path: Path) -> None:
    data = bytearray(path.read_bytes())
    _, at, length = next(r for r in _records(bytes(data)) if r[0] == 0x06)  # a Chunk record
    data[at + 8 + length - 20] ^= 0x10  # in its (compressed) records
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_a_flipped_byte_in_a_chunk_is_refused_naming_the_file(tmp_path: Path, messages, compression) -> None:
    path = write_mcap(tmp_path / "bag.mcap", messages, compression)
    whole = load_recording(path, cmd=CMD, phy=PHY)
    _flip_in_first_chunk(path)
    with pytest.raises(PegbtError, match="damaged MCAP file: .*after \\d+ readable messages") as raised:
        load_recording(path, cmd=CMD, phy=PHY)
    assert raised.value.file == str(path) and whole.n == 300


def test_a_huge_record_length_is_said_not_followed(tmp_path: Path, messages) -> None:
    path = write_mcap(tmp_path / "bag.mcap", messages, chunk_size=4096)
    data = bytearray(path.read_bytes())
    chunks = [at for opcode, at, _ in _records(bytes(data)) if opcode == 0x06]
    struct.pack_into("<Q", data, chunks[len(chunks) // 2], 2**62)  # a chunk in the middle
    path.write_bytes(bytes(data))
    recording = load_recording(path, cmd=CMD, phy=PHY)
    assert 0 < recording.n < 300 and "ends in the middle of a record" in recording.notes[0]


def test_a_bag_cut_short_is_diagnosed_with_a_warning_saying_so(tmp_path: Path, messages, capsys) -> None:
    whole = write_mcap(tmp_path / "whole.mcap", messages, chunk_size=4096)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: len(whole.read_bytes()) * 2 // 3])
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["sim2real", "diagnose", str(cut), "--cmd", CMD, "--phy", PHY, "--bootstrap", "0"]) == 0
    err = capsys.readouterr().err
    assert f"pegbt: warning: {cut}: the file ends in the middle of a record" in err
    assert "Traceback" not in err


def test_a_message_that_is_not_cdr_names_its_topic_and_index(tmp_path: Path, messages) -> None:
    bad = list(messages)
    topic, stamp, data = bad[41]  # message 20 of the tracker's topic
    bad[41] = (topic, stamp, data[:40] + b"\xff\xff\xff\x7f" + data[44:])  # a sequence length of 2**31
    path = write_mcap(tmp_path / "bag.mcap", bad)
    with pytest.raises(PegbtError, match=f"message 20 of {PHY} is not valid CDR") as raised:
        load_recording(path, cmd=CMD, phy=PHY)
    assert raised.value.field == PHY and "\n" not in str(raised.value)


def test_a_rosbag2_metadata_nested_30000_deep_is_refused_at_once(tmp_path: Path) -> None:
    folder = tmp_path / "bag"
    folder.mkdir()
    (folder / "metadata.yaml").write_text(
        "rosbag2_bagfile_information: " + "[" * 30_000 + "]" * 30_000 + "\n"
    )
    with pytest.raises(PegbtError, match="not a readable rosbag2 folder") as raised:
        load_recording(folder)
    assert raised.value.file == str(folder / "metadata.yaml")


def test_messages_no_checksum_covers_are_said(tmp_path: Path, messages) -> None:
    """An unchunked file written without a data-section CRC: a flipped bit in a message is a value like any
    other, so the reader says that nothing checked them."""
    path = write_mcap(tmp_path / "bag.mcap", messages, chunked=False)
    recording = load_recording(path, cmd=CMD, phy=PHY)
    assert recording.notes == (
        "600 of its 600 messages are covered by no checksum (written outside chunks, without a data-section "
        "CRC): damage to them could not be seen",
    )
    assert load_recording(write_mcap(tmp_path / "chunked.mcap", messages), cmd=CMD, phy=PHY).notes == ()


def test_a_chunk_whose_opcode_is_zeroed_is_found_missing_by_the_statistics(tmp_path: Path, messages) -> None:
    """A record of an unknown opcode is skipped, as MCAP's readers must: a chunk whose opcode byte is zeroed
    vanishes with its messages and no CRC fails, so only the summary's message count shows them missing."""
    path = write_mcap(tmp_path / "bag.mcap", messages, chunk_size=2048)
    data = bytearray(path.read_bytes())
    _, at, _ = [r for r in _records(bytes(data)) if r[0] == 0x06][3]  # the fourth chunk
    data[at - 1] = 0x00
    path.write_bytes(bytes(data))
    with pytest.raises(PegbtError, match=r"its statistics count 600 messages, \d+ could be read") as raised:
        load_recording(path, cmd=CMD, phy=PHY)
    assert raised.value.file == str(path)


def test_a_rosbag2_mcap_folder_is_read_by_its_chunks_past_indexes_with_bits_flipped(
    tmp_path: Path, messages
) -> None:
    """The MessageIndex and ChunkIndex records carry no CRC: read through them (as `rosbags`' reader does), a
    chunk's end time flipped earlier than its messages hides them. The chunks, each CRC-checked, still hold
    the bag whole."""
    folder = write_rosbag2(tmp_path / "bag", messages, random.Random(0), storage="mcap")
    whole = load_recording(folder, cmd=CMD, phy=PHY)
    (path,) = folder.glob("*.mcap")
    data = bytearray(path.read_bytes())
    # bit 38 of each ChunkIndex's message_end_time (275 s earlier or later) and of each MessageIndex's
    # first message time (after its channel id and its array's length)
    at_in_body = {0x08: 8 + 4, 0x07: 2 + 4 + 4}
    indexes = [r for r in _records(bytes(data)) if r[0] in at_in_body]
    for opcode, at, _ in indexes:
        data[at + 8 + at_in_body[opcode]] ^= 0x40
    path.write_bytes(bytes(data))
    read = load_recording(folder, cmd=CMD, phy=PHY)
    assert len(indexes) > 4 and whole.n == read.n == 300 and read.notes == ()
    np.testing.assert_array_equal(read.q_phy, whole.q_phy)
    np.testing.assert_array_equal(read.q_cmd, whole.q_cmd)


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_rosbag2_storage_file_outside_its_folder_is_refused_at_its_line(
    tmp_path: Path, messages, storage: str
) -> None:
    folder = write_rosbag2(tmp_path / "bag", messages, random.Random(0), storage=storage)
    (path,) = (p for p in folder.iterdir() if p.name != "metadata.yaml")
    path.rename(tmp_path / path.name)
    metadata = folder / "metadata.yaml"
    text = metadata.read_text()
    assert f"- {path.name}" in text
    metadata.write_text(text.replace(f"- {path.name}", f"- ../{path.name}"))
    line = 1 + text.split(f"- {path.name}")[0].count("\n")
    with pytest.raises(
        PegbtError, match=f"not a readable rosbag2 folder: ../{path.name} lies outside it"
    ) as raised:
        load_recording(folder, cmd=CMD, phy=PHY)
    assert (raised.value.file, raised.value.line) == (str(metadata), line)
    assert raised.value.field == "rosbag2_bagfile_information.relative_file_paths[0]"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_rosbag2_duration_that_is_no_number_is_refused_at_its_line(
    tmp_path: Path, messages, storage: str
) -> None:
    """A flipped byte in metadata.yaml's duration (the fuzz campaign's seed 22553397, which `rosbags` read and
    added to): an error at the field, before any reader opens the folder, not rosbags' TypeError."""
    folder = write_rosbag2(tmp_path / "bag", messages, random.Random(0), storage=storage)
    metadata = folder / "metadata.yaml"
    text = metadata.read_text()
    start = text.index("  duration:\n    nanoseconds: ") + len("  duration:\n    nanoseconds: ")
    metadata.write_text(text[:start] + "23x" + text[start + 3 :])
    with pytest.raises(PegbtError, match="nanoseconds is '23x.*', not a whole number") as raised:
        load_recording(folder, cmd=CMD, phy=PHY)
    assert (raised.value.file, raised.value.line) == (str(metadata), 1 + text[:start].count("\n"))
    assert raised.value.field == "rosbag2_bagfile_information.duration.nanoseconds"
