"""`pegbt monitor LOG`: a finished (or unfinished) tick log, its first causes and its world, for the page.

The log is checked by `read_tick_log` first (a corrupt log is a `PegbtError` naming the line); the page then
gets the records themselves, so that it steps through the same changes `pegbt log replay` applies.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pegbt.executive.logfile import read_tick_log
from pegbt.monitor.causes import marked_causes
from pegbt.monitor.world import read_world_log, world_log_path


def replay_messages(path: Path | str) -> list[dict[str, Any]]:
    """Every message the page needs to replay the tick log at `path`, in order."""
    path = Path(path)
    log = read_tick_log(path)
    records = [json.loads(line) for line in path.read_bytes().splitlines() if line.strip()]
    messages = [{"type": "mode", "mode": "replay", "log": str(path)}, *records]
    messages.append({"type": "causes", **marked_causes(log)})
    world = world_log_path(path)
    if world.exists():
        messages += read_world_log(world)
    return messages
