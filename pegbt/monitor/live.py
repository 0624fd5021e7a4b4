"""`pegbt run --monitor PORT`: the run's tick-log records, its world and, at the end, its first causes, to the page.

The hook into the run is the tick log's listeners (`TickLogWriter(listeners=...)`): `watch` is called by
`run_tree_file` once the tree is built and returns the listeners; the runner itself knows nothing of it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pegbt.executive.build import BuiltTree
from pegbt.executive.logfile import read_tick_log
from pegbt.monitor.causes import marked_causes
from pegbt.monitor.server import MonitorServer
from pegbt.monitor.world import WorldLogWriter, WorldSampler, scene, world_log_path

Listener = Callable[[dict[str, Any]], None]


class LiveMonitor:
    """Feeds `server` from the run that writes the tick log at `log_path`."""

    def __init__(self, server: MonitorServer, log_path: Path) -> None:
        self.server = server
        self.log_path = Path(log_path)
        self._world_log: WorldLogWriter | None = None

    def watch(self, built: BuiltTree, resources: Mapping[str, Any]) -> list[Listener]:
        """The listeners for this run: every record to the page; the world if a resource has arms."""
        self.server.publish({"type": "mode", "mode": "live", "log": str(self.log_path)})
        listeners: list[Listener] = [self._record]
        robot = next((r for r in resources.values() if isinstance(getattr(r, "arms", None), dict)), None)
        if robot is not None and hasattr(robot, "link"):
            self.server.publish(scene())
            self._world_log = WorldLogWriter(world_log_path(self.log_path))
            listeners.append(WorldSampler(robot, [self.server.publish, self._world_log]))
        return listeners

    def _record(self, record: dict[str, Any]) -> None:
        self.server.publish(record)
        if record["type"] == "end":
            self.server.publish({"type": "causes", **marked_causes(read_tick_log(self.log_path))})

    def serve_until_interrupted(self) -> None:
        """After the run: keep the page up until Ctrl-C, then stop."""
        self._close_world_log()
        try:
            self.server.serve_until_interrupted("the run has ended; its page is still")
        finally:
            self.stop()

    def stop(self) -> None:
        self._close_world_log()
        self.server.stop()

    def _close_world_log(self) -> None:
        if self._world_log is not None:
            self._world_log.close()
