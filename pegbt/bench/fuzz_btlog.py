"""The `.btlog` campaign: `pegbt log export` of mutated tick logs, each export checked against the layout
BehaviorTree.CPP's FileLogger2 reads (`pegbt.executive.btlog`), and damaged `.btlog` files given where a tick
log belongs (`pegbt log summary X.btlog`), which must be refused naming what they are. An export that writes
a file Groot2 could not read, or a `.btlog` read as a tick log, counts as `absurd_accepted`."""

from __future__ import annotations

import json
import random
import struct
from functools import partial
from pathlib import Path
from xml.etree import ElementTree

from pegbt.bench.fuzzing import SILENT, Tally

RECORD = 9  # 6-byte µs offset, uint16 uid, uint8 status


def _well_formed(data: bytes, nodes: int) -> bool:
    """Whether `data` is a FileLogger2 file: magic, protocol 1, its XML, a start time, 9-byte records of
    known uids and statuses."""
    from pegbt.executive.btlog import MAGIC, PROTOCOL

    head = len(MAGIC) + 1
    if not data.startswith(MAGIC) or data[len(MAGIC)] != PROTOCOL or len(data) < head + 4:
        return False
    (size,) = struct.unpack_from("<i", data, head)
    body = head + 4 + size
    if size <= 0 or len(data) < body + 8 or (len(data) - body - 8) % RECORD:
        return False
    try:
        ElementTree.fromstring(data[head + 4 : body])
    except ElementTree.ParseError:
        return False
    records = data[body + 8 :]
    return all(
        1 <= struct.unpack_from("<H", records, at + 6)[0] <= nodes and records[at + 8] <= 3
        for at in range(0, len(records), RECORD)
    )


def fuzz_btlog(count: int, rng: random.Random, work: Path) -> Tally:
    from pegbt.bench.fuzz_bags import damage_bytes
    from pegbt.bench.fuzzing import mutate_records
    from pegbt.executive.btlog import export_btlog
    from pegbt.executive.logfile import read_tick_log
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file

    valid = work / "valid.jsonl"
    example = Path(__file__).resolve().parents[2] / "trees" / "example.yaml"
    run_tree_file(RunOptions(example, valid, clock="manual"))
    records = [json.loads(line) for line in valid.read_text().splitlines()]
    exported = work / "valid.btlog"
    export_btlog(read_tick_log(valid), exported)
    whole = exported.read_bytes()
    tally = Tally()
    for n in range(count):
        if rng.random() < 0.4:
            damaged, what = damage_bytes(whole, rng, [])
            path = work / f"damaged-{n}.btlog"
            path.write_bytes(damaged)
            tally.record(
                partial(read_tick_log, path),
                parsed=False,
                absurd=True,
                what=f"read as a tick log: {what}",
            )
            path.unlink()
            continue
        mutated = json.loads(json.dumps(records))
        _, what = mutate_records(mutated, rng)
        path = work / f"log-{n}.jsonl"
        path.write_text("".join((json.dumps(r) if not isinstance(r, str) else r) + "\n" for r in mutated))
        out = work / f"out-{n}.btlog"

        def export(path: Path = path, out: Path = out) -> object:
            log = read_tick_log(path)
            export_btlog(log, out)
            return True if _well_formed(out.read_bytes(), len(log.nodes)) else SILENT

        tally.record(export, parsed=True, absurd=False, what=f"export: {what}")
        path.unlink()
        out.unlink(missing_ok=True)
    return tally
