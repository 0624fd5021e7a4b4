"""The bag readers' campaign: MCAP files and rosbag2 folders read as `pegbt sim2real diagnose BAG --cmd
--phy` and `pegbt calibrate train BAG --cmd --phy` read them (`load_recording`).

Valid bags are written by the libraries ROS 2 uses (`mcap`'s writer, `rosbags`' rosbag2 writer), from
recordings of an arm, then damaged as disks and crashes damage files (cut short, bytes flipped, a record's
length made huge, a block zeroed) or written whole with contents that are not an arm's (degrees, ×100,
noise, NaN, five joints). A damaged bag read as if whole (no note of what was read past, values other than
those written) counts as `absurd_accepted`, as a recording not an arm's does; a bag undamaged and an arm's
that is refused counts as `good_refused`.
"""

from __future__ import annotations

import math
import random
import shutil
import struct
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

from pegbt.bench.fuzzing import REPORTED, SILENT, Tally, mutate_text

JOINT_STATE = "sensor_msgs/msg/JointState"
CMD, PHY = "/PSM1/setpoint_js", "/PSM1/tracker_js"
SAMPLES = 240
MCAP_MAGIC = b"\x89MCAP0\r\n"

Arrays = tuple[np.ndarray, np.ndarray, np.ndarray]  # t, q_cmd, q_phy


@lru_cache(maxsize=1)
def _bases() -> list[tuple[Arrays, list[tuple[str, int, bytes]]]]:
    """Streams of an arm at 100 Hz (`pegbt sim2real synth`'s families), with their messages as bags hold them."""
    from pegbt.sim2real.synth import generate

    bases = []
    for family, seed in (("weak", 0), ("masked", 1), ("null-white", 0)):
        recording = generate(family, seed).recording.slice(0, SAMPLES)
        arrays = (1.7e9 + recording.times, recording.q_cmd, recording.q_phy)
        bases.append((arrays, messages_of(arrays)))
    return bases


@lru_cache(maxsize=1)
def _store() -> Typestore:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _cdr(stamp: float, q: np.ndarray) -> bytes:
    store = _store()
    sec = math.floor(stamp)
    message = store.types[JOINT_STATE](
        header=store.types["std_msgs/msg/Header"](
            stamp=store.types["builtin_interfaces/msg/Time"](
                sec=sec, nanosec=min(round((stamp - sec) * 1e9), 999_999_999)
            ),
            frame_id="",
        ),
        name=[f"q{i + 1}" for i in range(len(q))],
        position=np.asarray(q, dtype=float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    return bytes(store.serialize_cdr(message, JOINT_STATE))


def messages_of(arrays: Arrays) -> list[tuple[str, int, bytes]]:
    """(topic, log time ns, CDR) interleaved as a recorder writes them."""
    t, q_cmd, q_phy = arrays
    out = []
    for stamp, command, physical in zip(t, q_cmd, q_phy):
        out.append((CMD, round(stamp * 1e9), _cdr(stamp, command)))
        out.append((PHY, round(stamp * 1e9), _cdr(stamp, physical)))
    return out


def write_mcap(
    path: Path,
    messages: list[tuple[str, int, bytes]],
    compression: str = "zstd",
    chunk_size: int = 16384,
    chunked: bool = True,
) -> Path:
    """A lone MCAP file by the `mcap` library's writer (CRCs on, as it writes them by default)."""
    from mcap.writer import CompressionType, Writer

    msgdef = _store().generate_msgdef(JOINT_STATE, ros_version=2)[0]
    with path.open("wb") as stream:
        writer = Writer(
            stream,
            chunk_size=chunk_size,
            compression=CompressionType[compression.upper()],
            use_chunking=chunked,
        )
        writer.start(profile="ros2", library="pegbt bench fuzz")
        schema = writer.register_schema(name=JOINT_STATE, encoding="ros2msg", data=msgdef.encode())
        channels = {topic: writer.register_channel(topic, "cdr", schema) for topic in (CMD, PHY)}
        for topic, stamp_ns, data in messages:
            writer.add_message(channels[topic], log_time=stamp_ns, data=data, publish_time=stamp_ns)
        writer.finish()
    return path


def _write_mcap(path: Path, messages: list[tuple[str, int, bytes]], rng: random.Random) -> Path:
    return write_mcap(
        path,
        messages,
        rng.choice(["zstd", "zstd", "lz4", "none"]),
        rng.choice([2048, 16384, 1 << 20]),
        rng.random() < 0.85,
    )


def write_rosbag2(
    folder: Path, messages: list[tuple[str, int, bytes]], rng: random.Random, storage: str | None = None
) -> Path:
    """A rosbag2 folder by `rosbags`' writer, in `storage` ("mcap" or "sqlite3"; by default one of them at
    random, MCAP twice as often)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _store()
    plugins = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
    plugin = (
        plugins[storage]
        if storage
        else rng.choice([StoragePlugin.MCAP, StoragePlugin.MCAP, StoragePlugin.SQLITE3])
    )
    with Writer(folder, version=9, storage_plugin=plugin) as writer:
        connections = {
            topic: writer.add_connection(topic, JOINT_STATE, typestore=store) for topic in (CMD, PHY)
        }
        for topic, stamp_ns, data in messages:
            writer.write(connections[topic], stamp_ns, data)
    for path in folder.glob("*.mcap"):
        _with_crcs(path, rng)
    return folder


def _with_crcs(path: Path, rng: random.Random) -> None:
    """Rewrite a rosbag2 MCAP storage file in chunks with their CRCs, as rosbag2's own storage plugin (the
    mcap C++ writer, chunk CRCs on by default) writes it; rosbags' writer leaves them 0."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with path.open("rb") as stream:
        records = list(make_reader(stream).iter_messages(log_time_order=False))
    with path.open("wb") as stream:
        writer = Writer(stream, chunk_size=rng.choice([2048, 16384]), compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="rosbag2 (pegbt bench fuzz)")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in records:
            assert schema is not None  # every rosbag2 channel has its message type's schema
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            writer.add_message(
                channels[channel.id], message.log_time, message.data, message.publish_time, message.sequence
            )
        writer.finish()


# ------------------------------------------------------------------------------------------ contents
def _not_an_arm(arrays: Arrays, rng: random.Random) -> tuple[Arrays, str]:
    """Contents that are not an arm's, written whole."""
    t, q_cmd, q_phy = (a.copy() for a in arrays)
    kind = rng.choice(["degrees", "x100", "millimetres", "noise", "non-finite", "five joints"])
    if kind == "degrees":
        q_cmd, q_phy = np.degrees(q_cmd), np.degrees(q_phy)
    elif kind == "x100":
        q_cmd, q_phy = 100 * q_cmd, 100 * q_phy
    elif kind == "millimetres":
        q_cmd[:, 2] *= 1000
        q_phy[:, 2] *= 1000
    elif kind == "noise":
        q_phy = np.random.default_rng(rng.randrange(2**32)).uniform(-1.4, 1.4, q_phy.shape)
        q_phy[:, 2] = 0.16
    elif kind == "non-finite":
        q_cmd[rng.randrange(len(q_cmd)), rng.randrange(6)] = rng.choice([math.nan, math.inf, -math.inf])
    else:
        q_cmd, q_phy = q_cmd[:, :5], q_phy[:, :5]
    return (t, q_cmd, q_phy), kind


# -------------------------------------------------------------------------------------------- damage
def _record_lengths(data: bytes) -> list[int]:
    """Offsets of the length fields of an MCAP file's top-level records (opcode, uint64 length, content)."""
    offsets, at = [], len(MCAP_MAGIC)
    while at + 9 <= len(data):
        length = struct.unpack_from("<Q", data, at + 1)[0]
        offsets.append(at + 1)
        at += 9 + length
    return offsets


def damage_bytes(data: bytes, rng: random.Random, lengths: list[int]) -> tuple[bytes, str]:
    """`data` cut short, with bytes flipped, a length field made huge, or a block zeroed."""
    raw = bytearray(data)
    kind = rng.choice(["truncate", "flip", "flip", "huge length", "zeroed block"])
    if kind == "truncate":
        cut = rng.randrange(len(raw))
        return bytes(raw[:cut]), f"cut at byte {cut} of {len(raw)}"
    if kind == "huge length" and lengths:
        at = rng.choice(lengths)
        value = rng.choice(
            [2**63 - 1, 2**40, 2**32 + 7, struct.unpack_from("<Q", raw, at)[0] + rng.randint(1, 64)]
        )
        struct.pack_into("<Q", raw, at, value)
        return bytes(raw), f"record length at byte {at} set to {value}"
    if kind == "zeroed block":
        size = rng.randint(16, 4096)
        at = rng.randrange(max(len(raw) - size, 1))
        raw[at : at + size] = bytes(len(raw[at : at + size]))
        return bytes(raw), f"{size} bytes zeroed at byte {at}"
    flips = []
    for _ in range(rng.randint(1, 16)):
        at = rng.randrange(len(raw))
        raw[at] ^= 1 << rng.randrange(8)
        flips.append(at)
    return bytes(raw), f"bits flipped at bytes {sorted(flips)[:4]}"


def _verdict(path: Path, arrays: Arrays, damaged: bool, good: bool) -> Callable[[], object]:
    """Read `path` as the CLI does; a damaged bag read as if whole with other values is not accepted."""
    from pegbt.physics.recording import load_recording

    def read() -> object:
        recording = load_recording(path, cmd=CMD, phy=PHY)
        if recording.notes:
            return REPORTED
        t, q_cmd, q_phy = arrays
        whole = (
            recording.n == len(t)
            and np.array_equal(recording.q_cmd, q_cmd)
            and np.array_equal(recording.q_phy, q_phy)
        )
        return SILENT if damaged and not whole else True

    return read


def _campaign(count: int, rng: random.Random, work: Path, rosbag2: bool) -> Tally:
    bases = _bases()
    tally = Tally()
    for n in range(count):
        arrays, messages = rng.choice(bases)
        target = work / (f"bag-{n}" if rosbag2 else f"bag-{n}.mcap")
        choice = rng.random()
        absurd = good = damaged = False
        if choice < 0.15:
            arrays, what = _not_an_arm(arrays, rng)
            messages, absurd = messages_of(arrays), True
        elif choice < 0.25:
            what, good = "whole", True
        write = write_rosbag2 if rosbag2 else _write_mcap
        write(target, messages, rng)
        if choice >= 0.25:
            damaged = True
            what = _damage_bag(target, rng, rosbag2)
        tally.record(
            _verdict(target, arrays, damaged, good),
            parsed=not damaged,
            absurd=absurd,
            good=good,
            what=what,
        )
        shutil.rmtree(target) if target.is_dir() else target.unlink()
    return tally


def _damage_bag(target: Path, rng: random.Random, rosbag2: bool) -> str:
    """Damage the MCAP file, or one file of the rosbag2 folder (its storage file or metadata.yaml)."""
    if rosbag2:
        # sqlite3 storage keeps no checksum of its messages: a flipped bit in one is a value like any other,
        # which no reader can tell, so only its metadata is damaged here
        files = sorted(p for p in target.iterdir() if p.is_file() and p.suffix != ".db3")
        path = rng.choice(files)
        if path.name == "metadata.yaml" and rng.random() < 0.5:
            text, _, what = mutate_text(path.read_text(), rng)
            path.write_text(text, encoding="utf-8", errors="surrogateescape")
            return f"metadata.yaml: {what}"
    else:
        path = target
    data = path.read_bytes()
    lengths = _record_lengths(data) if data.startswith(MCAP_MAGIC) else []
    damaged, what = damage_bytes(data, rng, lengths)
    path.write_bytes(damaged)
    return f"{path.name}: {what}"


def fuzz_mcap(count: int, rng: random.Random, work: Path) -> Tally:
    return _campaign(count, rng, work, rosbag2=False)


def fuzz_rosbag2(count: int, rng: random.Random, work: Path) -> Tally:
    return _campaign(count, rng, work, rosbag2=True)
