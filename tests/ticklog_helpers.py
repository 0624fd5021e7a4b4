"""A valid tick log of the example tree, and copies of it with its node table changed, for the tests of
what the readers and the export do with a node table another writer could leave."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file

REPO = Path(__file__).resolve().parents[1]


def example_records(folder: Path) -> list[dict]:
    """The records of one manual-clock run of `trees/example.yaml`, logged in `folder`."""
    log = folder / "valid.jsonl"
    run_tree_file(RunOptions(REPO / "trees" / "example.yaml", log, clock="manual"))
    return [json.loads(line) for line in log.read_text().splitlines()]


def changed_log(folder: Path, records: list[dict], change: Callable[[list[dict]], Any]) -> tuple[Path, Any]:
    """`records` written to `folder` after `change` edited a copy of the header's node table; with what
    `change` returned."""
    changed = json.loads(json.dumps(records))
    returned = change(changed[0]["nodes"])
    log = folder / "changed.jsonl"
    log.write_text("".join(json.dumps(record) + "\n" for record in changed))
    return log, returned
