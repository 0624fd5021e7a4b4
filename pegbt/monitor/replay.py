"""`pegbt monitor LOG`: a finished (or unfinished) tick log, its first causes and its world, for the page.

The log is read by `read_tick_log` (a corrupt log is a `PegbtError` naming the line); the page then gets
the records it read, so that it steps through the same changes `pegbt log replay` applies (a crash's cut
last line left out, a record repeated word for word once).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pegbt.executive.logfile import TickLog, read_tick_log
from pegbt.monitor.causes import marked_causes
from pegbt.monitor.world import read_world_log, world_log_path


def replay_messages(source: Path | str | TickLog) -> list[dict[str, Any]]:
    """Every message the page needs to replay a tick log (a path, or one read with `keep_records`), in order."""
    log = source if isinstance(source, TickLog) else read_tick_log(source, keep_records=True)
    assert log.records is not None, "a TickLog given to the replay is read with keep_records=True"
    path = log.path
    messages = [{"type": "mode", "mode": "replay", "log": str(path)}, *log.records]
    messages.append({"type": "causes", **marked_causes(log)})
    world = world_log_path(path)
    if world.exists():
        messages += read_world_log(world)
    return messages
