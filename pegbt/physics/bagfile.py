"""Commanded and physical joints from a ROS 2 bag: an MCAP file, or a rosbag2 folder (MCAP or sqlite3).

A bag holds two `sensor_msgs/msg/JointState` streams, the commands (`--cmd`, default
`/PSMn/setpoint_js`) and the physical joints (`--phy`, default `/PSMn/fiducial_js`, the simulator's; on a
dVRK the tracker's topic). Each physical sample is paired with the latest command stamped at or before
it (header stamps; the log time when a stamp is zero), so a bag with one message per set-point on each
topic gives the samples of the folder layout. `settled` keeps only samples whose command had then held
for that many seconds. An MCAP file, alone or a rosbag2 folder's storage, is read by the `mcap` library's
stream reader, which checks every CRC and also reads a file cut short up to the cut; other rosbag2 storage
(sqlite3, files compressed whole) by `rosbags`' reader. Payloads are CDR, decoded by
`rosbags`' typestore.
"""

from __future__ import annotations

import re
import sqlite3
import struct
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.bagoptions import DEFAULT_CMD, DEFAULT_PHY
from pegbt.errors import PegbtError
from pegbt.psm import ARMS, N_JOINTS
from pegbt.scratch import ROWS, ScratchRows, scratch, scratch_where
from pegbt.yamlfile import Located, read_yaml_file

JOINT_STATE = "sensor_msgs/msg/JointState"
_ARM_IN_TOPIC = re.compile(r"(?:^|/)(PSM[12])(?:/|$)")

Array = NDArray[np.float64]


@dataclass(frozen=True)
class BagSamples:
    """Paired samples of one arm from a bag: (N, 6) commands and physical joints, N stamps (s)."""

    q_cmd: Array
    q_phy: Array
    t: Array
    arm: str | None
    notes: tuple[str, ...] = ()  # what the reader read past: a file cut short


def is_bag(path: Path) -> bool:
    """An MCAP file, or a folder with rosbag2's `metadata.yaml`."""
    return path.suffix.lower() == ".mcap" and path.is_file() or (path / "metadata.yaml").is_file()


def _damage(reader_error: type[Exception]) -> tuple[type[Exception], ...]:
    """What the readers raise on bytes that are not what the format says: the reader's own error, corrupt
    compression (zstandard's ZstdError for mcap, backports.zstd's for rosbags, lz4's RuntimeError), a CRC that
    disagrees (mcap's CRCValidationError is a ValueError), records cut or garbled (struct.error,
    UnicodeDecodeError, KeyError), a damaged sqlite3 database (rosbags reads it through apsw)."""
    from apsw import Error as ApswError
    from backports.zstd import ZstdError as RosbagsZstdError
    from zstandard import ZstdError

    return (
        reader_error,
        ZstdError,
        RosbagsZstdError,
        ApswError,
        ValueError,
        RuntimeError,
        struct.error,
        KeyError,
        IndexError,
        EOFError,
        MemoryError,
        OverflowError,
        sqlite3.Error,
    )


def _raw_messages(
    path: Path, topics: dict[str, str], notes: list[str]
) -> Iterator[tuple[str, str, bytes, int]]:
    """(topic, type, CDR payload, log time ns) of every message of the bag; `topics` learns every topic's
    type, `notes` what was read past (a file cut short). Damage is a `PegbtError` naming the file."""
    if path.is_dir():
        yield from _rosbag2_messages(path, topics, notes)
    else:
        yield from _mcap_messages(path, topics, notes)


def _rosbag2_messages(
    path: Path, topics: dict[str, str], notes: list[str]
) -> Iterator[tuple[str, str, bytes, int]]:
    """A rosbag2 folder: its MCAP storage files one by one as a lone MCAP file is read (`_mcap_messages`),
    in chunks whose CRCs are checked, never through the summary's indexes, which no CRC covers (a flipped
    bit in one steers an indexed reader to other messages, read as whole); other storage (sqlite3, files
    compressed whole) through `rosbags`."""
    try:  # bounded in size and depth, as rosbags' parser is not
        metadata = read_yaml_file(path / "metadata.yaml")
    except PegbtError as error:
        raise PegbtError(
            f"not a readable rosbag2 folder: {error.message}",
            file=error.file,
            line=error.line,
            column=error.column,
        ) from None
    info = metadata.value.get("rosbag2_bagfile_information") if metadata and metadata.is_map else None
    if info is not None:
        _whole_counts(info)
    files = _storage_files(path, info)
    plain = info.plain() if info and info.is_map else {}
    if files is None or plain.get("storage_identifier") != "mcap" or plain.get("compression_format"):
        yield from _rosbags_messages(path, topics)
        return
    for file in files:
        yield from _mcap_messages(file, topics, notes)


WHOLE_FIELDS = frozenset({"nanoseconds", "nanoseconds_since_epoch", "message_count", "version"})


def _whole_counts(info: Located) -> None:
    """Every count and time of a rosbag2 folder's metadata a whole number, else an error at its line:
    `rosbags` adds to them unchecked (a flipped byte turning a duration into text raised its TypeError)."""
    if info.is_list:
        for item in info.value:
            _whole_counts(item)
    if not info.is_map:
        return
    for key, item in info.value.items():
        number = item.value
        if key in WHOLE_FIELDS and not (isinstance(number, int) and not isinstance(number, bool)):
            raise item.error(f"not a readable rosbag2 folder: {key} is {number!r}, not a whole number")
        _whole_counts(item)


def _storage_files(path: Path, info: Located | None) -> list[Path] | None:
    """The storage files a rosbag2 folder's metadata (`info`) lists, each checked to lie in the folder and
    be there (an error at its line otherwise, before any reader opens it); None when it lists none."""
    names = info.value.get("relative_file_paths") if info and info.is_map else None
    if names is None or not names.is_list or not all(isinstance(n.value, str) for n in names.value):
        return None
    folder = path.resolve()
    files = []
    for name in names.value:
        file = (path / name.value).resolve()
        if not file.is_relative_to(folder):
            raise name.error(f"not a readable rosbag2 folder: {name.value} lies outside it")
        if not file.is_file():
            raise name.error(f"not a readable rosbag2 folder: it has no file {name.value}")
        files.append(file)
    return files


def _rosbags_messages(path: Path, topics: dict[str, str]) -> Iterator[tuple[str, str, bytes, int]]:
    """A rosbag2 folder through `rosbags`' reader."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag2 import ReaderError

    count = 0
    try:
        with AnyReader([path]) as reader:
            topics.update({c.topic: c.msgtype for c in reader.connections})
            for connection, log_time, data in reader.messages():
                yield connection.topic, connection.msgtype, bytes(data), log_time
                count += 1
    except AnyReaderError as error:
        raise PegbtError(f"not a readable rosbag2 folder: {_one_line(error)}", file=path) from None
    except _damage(ReaderError) as error:
        raise PegbtError(
            f"damaged rosbag2 folder: {_one_line(error)} (after {count} readable messages)", file=path
        ) from None


def _mcap_messages(
    path: Path, topics: dict[str, str], notes: list[str]
) -> Iterator[tuple[str, str, bytes, int]]:
    """A lone MCAP file through the `mcap` library's stream reader, every CRC it offers checked (each
    chunk's, and the data section's once its end is read) and the messages read counted against the summary's
    Statistics record (a zeroed block reads as empty records, and the messages in it vanish); a file cut
    short reads up to the cut, and messages no CRC covers (outside chunks, no data-section CRC) are
    counted: both noted."""
    from mcap.exceptions import EndOfFile, InvalidMagic, McapError, RecordLengthLimitExceeded
    from mcap.records import Channel, Chunk, DataEnd, Message, Schema, Statistics
    from mcap.stream_reader import StreamReader, breakup_chunk

    size = path.stat().st_size
    count = unchecked = 0
    counted: int | None = None  # what the summary's Statistics record says the file holds
    data_crc = False
    schemas: dict[int, str] = {}
    channels: dict[int, Channel] = {}
    with path.open("rb") as stream:
        reader = StreamReader(stream, emit_chunks=True, validate_crcs=True, record_size_limit=max(size, 1))
        try:
            for record in reader.records:
                inner = breakup_chunk(record, validate_crc=True) if isinstance(record, Chunk) else [record]
                covered = isinstance(record, Chunk) and record.uncompressed_crc != 0
                data_crc |= isinstance(record, DataEnd) and record.data_section_crc != 0
                if isinstance(record, Statistics):
                    counted = record.message_count
                for item in inner:
                    if isinstance(item, Schema):
                        schemas[item.id] = item.name
                    elif isinstance(item, Channel):
                        channels[item.id] = item
                        topics[item.topic] = schemas.get(item.schema_id, "")
                    elif isinstance(item, Message):
                        channel = channels.get(item.channel_id)
                        if channel is None:
                            raise McapError(
                                f"message {count} is on channel {item.channel_id}, never declared"
                            )
                        unchecked += not covered
                        yield channel.topic, topics[channel.topic], item.data, item.log_time
                        count += 1
        except (EndOfFile, EOFError, RecordLengthLimitExceeded) as error:  # a record runs past the end
            if not topics:
                reason = (
                    f"it ends after {size} bytes, before its first channel"
                    if size == stream.tell() or not isinstance(error, EndOfFile)
                    else _one_line(error)
                )
                raise PegbtError(f"not a readable MCAP file: {reason}", file=path) from None
            notes.append(
                f"the file ends in the middle of a record (a recording cut short, or a length past its end): "
                f"{count} messages read before byte {stream.tell()} of {size}"
            )
        except _damage(McapError) as error:
            if isinstance(error, InvalidMagic):
                raise PegbtError(f"not a readable MCAP file: {_one_line(error)}", file=path) from None
            where = f"after {count} readable messages, at byte {stream.tell()} of {size}"
            raise PegbtError(f"damaged MCAP file: {_one_line(error)} ({where})", file=path) from None
    if counted is not None and counted != count:
        raise PegbtError(
            f"damaged MCAP file: its statistics count {counted} messages, {count} could be read", file=path
        )
    if unchecked and not data_crc:
        notes.append(
            f"{unchecked} of its {count} messages are covered by no checksum (written outside chunks, without "
            "a data-section CRC): damage to them could not be seen"
        )


def _one_line(error: Exception) -> str:
    """A reader's message on one line (rosbags quotes YAML parser errors over several)."""
    return " ".join(str(error).split()) or type(error).__name__


def _joint_stream(
    path: Path, topic: str, kind: str, rows: ScratchRows | None, malformed: tuple[int, int] | None
) -> Array:
    """A topic's (stamp, six joints) rows in order of stamp, a state re-sent unchanged once, in scratch."""
    if kind != JOINT_STATE:
        raise PegbtError(
            f"topic {topic} holds {kind or 'untyped messages'}, not {JOINT_STATE}", file=path, field=topic
        )
    if rows is None:
        raise PegbtError(f"topic {topic} has no messages", file=path, field=topic)
    if malformed is not None:
        raise PegbtError(
            f"message {malformed[0]} of {topic} has {malformed[1]} joint positions; an arm has {N_JOINTS}",
            file=path,
            field=topic,
        )
    stream = rows.array()
    stamps = stream[:, 0]
    if not np.all(stamps[1:] >= stamps[:-1]):  # a bag's messages in the order logged, not stamped
        order = np.argsort(stamps, kind="stable")
        ordered = scratch(stream.shape)
        for a in range(0, len(order), ROWS):
            ordered[a : a + ROWS] = stream[order[a : a + ROWS]]
        stream = ordered
    last_of_stamp = np.r_[stream[1:, 0] != stream[:-1, 0], True]  # a state re-sent unchanged counts once
    return stream if last_of_stamp.all() else scratch_where(stream, last_of_stamp)


def _bag_arm(path: Path, arm: str | None, cmd: str | None, phy: str | None) -> str | None:
    if arm is not None:
        return arm
    for topic in (cmd, phy):
        match = _ARM_IN_TOPIC.search(topic or "")
        if match:
            return match.group(1)
    return None


def read_bag(
    path: Path,
    *,
    cmd: str | None = None,
    phy: str | None = None,
    arm: str | None = None,
    settled: float | None = None,
) -> BagSamples:
    """Paired samples of `cmd` and `phy`; a `PegbtError` naming the file and topic for a bag that has none."""
    from rosbags.serde import SerdeError
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.stores.ros2_jazzy import sensor_msgs__msg__JointState

    arm = _bag_arm(path, arm, cmd, phy)
    topics: dict[str, str] = {}
    rows: dict[str, ScratchRows] = {}  # each topic's (stamp, six joints), decoded into scratch
    counts: dict[str, int] = {}
    malformed: dict[str, tuple[int, int]] = {}  # a topic's first message without six joints, and its count
    notes: list[str] = []
    store = get_typestore(Stores.ROS2_JAZZY)
    wanted = None if arm is None else {cmd or DEFAULT_CMD.format(arm=arm), phy or DEFAULT_PHY.format(arm=arm)}
    for topic, kind, data, log_time in _raw_messages(path, topics, notes):
        if kind != JOINT_STATE or (wanted is not None and topic not in wanted):
            continue
        try:
            message = store.deserialize_cdr(data, JOINT_STATE)
        except (SerdeError, ValueError, IndexError, struct.error, UnicodeDecodeError, MemoryError) as error:
            index = counts.get(topic, 0)
            raise PegbtError(
                f"message {index} of {topic} is not valid CDR: {_one_line(error)}", file=path, field=topic
            ) from None
        assert isinstance(message, sensor_msgs__msg__JointState)  # the store's class for JOINT_STATE
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9 or log_time * 1e-9
        index = counts.get(topic, 0)
        counts[topic] = index + 1
        stream = rows.get(topic) or rows.setdefault(topic, ScratchRows(1 + N_JOINTS))
        if len(message.position) != N_JOINTS:
            malformed.setdefault(topic, (index, len(message.position)))
        elif topic not in malformed:
            stream.append((stamp, *message.position))
    if not topics:
        raise PegbtError("the bag is empty: no topics, no messages", file=path)
    if arm is None:
        arms = [name for name in ARMS if DEFAULT_PHY.format(arm=name) in topics]  # the arm tracked, else
        if len(arms) != 1:  # the one arm the topics name
            arms = sorted({match.group(1) for topic in topics if (match := _ARM_IN_TOPIC.search(topic))})
        if len(arms) != 1:
            raise PegbtError(
                f"which arm? the bag's topics name {' and '.join(arms) or 'neither arm'}: give --arm, or --cmd "
                "and --phy",
                file=path,
            )
        arm = arms[0]
    cmd, phy = cmd or DEFAULT_CMD.format(arm=arm), phy or DEFAULT_PHY.format(arm=arm)
    for topic in (cmd, phy):
        if topic not in topics:
            raise PegbtError(
                f"no topic {topic} in the bag (it has {', '.join(sorted(topics))})", file=path, field=topic
            )
    commands = _joint_stream(path, cmd, topics[cmd], rows.get(cmd), malformed.get(cmd))
    physical = _joint_stream(path, phy, topics[phy], rows.get(phy), malformed.get(phy))
    return replace(_paired(path, cmd, phy, commands, physical, arm, settled), notes=tuple(notes))


def _paired(
    path: Path, cmd: str, phy: str, commands: Array, physical: Array, arm: str, settled: float | None
) -> BagSamples:
    """Each physical sample with the latest command at or before it; with `settled`, only held commands.
    Paired `ROWS` physical samples at a time into scratch (`pegbt.scratch`)."""
    command_stamps = scratch((len(commands),))
    command_stamps[:] = commands[:, 0]
    since = None
    if settled is not None:
        changed = np.r_[True, (np.diff(commands[:, 1:], axis=0) != 0).any(axis=1)]
        since = np.maximum.accumulate(np.where(changed, np.arange(len(commands)), 0))
    q_cmd, q_phy, t = (
        scratch((len(physical), N_JOINTS)),
        scratch((len(physical), N_JOINTS)),
        scratch((len(physical),)),
    )
    overlap, kept = False, 0
    for a in range(0, len(physical), ROWS):
        stamps = physical[a : a + ROWS, 0]
        latest = np.searchsorted(command_stamps, stamps, side="right") - 1
        keep = latest >= 0
        overlap |= bool(keep.any())
        if since is not None and settled is not None:
            keep &= stamps - commands[since[np.maximum(latest, 0)], 0] >= settled
        count = int(keep.sum())
        q_cmd[kept : kept + count] = commands[latest[keep], 1:]
        q_phy[kept : kept + count] = physical[a : a + ROWS][keep, 1:]
        t[kept : kept + count] = stamps[keep]
        kept += count
    if not overlap:
        raise PegbtError(
            f"no overlap in time: every {phy} message ({physical[0, 0]:.9g}–{physical[-1, 0]:.9g} s) is "
            f"stamped before the first {cmd} message ({commands[0, 0]:.9g} s)",
            file=path,
            field=phy,
        )
    if not kept:
        raise PegbtError(
            f"no {phy} sample comes {settled:g} s or more after its command last changed",
            file=path,
            field="settled",
        )
    return BagSamples(q_cmd[:kept], q_phy[:kept], t[:kept], arm)
