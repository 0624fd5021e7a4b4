"""The 3D scene beside the tree: board, pegs, both tools, the last point cloud and the blocks.

Everything is in the board frame (metres; z points down into the board, as in `skills/workcell.yaml`); the
page turns it up. `scene()` is what never changes (from `pegbt.workcell`). A `WorldSampler` listens to a live
run's tick log and, at most every `period` seconds of run time and whenever perception writes, samples:
each arm's tool as segments from its published joints (`measured_js`, forward kinematics through
`pegbt.motion.handover.tool_segments`), the last cloud from the blackboard (camera to board through the
registered board, thinned to `CLOUD_POINTS`), the blocks as perception believes them (`/blocks`) and, when
the robot is the simulator, its ground truth (`sim/truth`: the blocks, labelled as such by the page, and
the faults it injected, which `pegbt log plot` marks). Samples go to
the page and to a sidecar next to the tick log (`world_log_path`), so that a replay shows them too.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np
import py_trees

from pegbt.errors import PegbtError
from pegbt.frames import apply_rigid
from pegbt.motion.handover import tool_segments
from pegbt.sim.truth import ask_truth
from pegbt.workcell import Workcell, workcell

CLOUD_POINTS = 4000  # points of a capture sent to the page (of ~130 000): enough to see the board and blocks
TRUTH_PERIOD = 0.25  # s of run time between two questions to the simulator
PERCEPTION_KEYS = ("/cloud", "/blocks", "/board")
LOG = logging.getLogger("pegbt.monitor")


def world_log_path(tick_log: Path | str) -> Path:
    """The world sidecar of a tick log: `run.jsonl` -> `run.world.jsonl`."""
    path = Path(tick_log)
    return path.with_name(path.stem + ".world.jsonl")


def scene(cell: Workcell | None = None) -> dict[str, Any]:
    """The static part of the scene: board extent and surface, peg tops and size, the block's outline."""
    cell = cell or workcell()
    return {
        "type": "scene",
        "board": {
            "x": list(cell.board.extent_x),
            "y": list(cell.board.extent_y),
            "z": cell.board.surface_z,
            "thickness": cell.board.thickness,
        },
        "pegs": {
            "tops": _rounded(cell.pegs.tops),
            "radius": cell.pegs.radius,
            "base_z": cell.board.surface_z,
        },
        "block": {"outline": _rounded(cell.block.outline), "height": cell.block.height},
        "arms": {arm: _rounded(cell.remote_centre(arm)) for arm in cell.arm_from_board},
    }


def _rounded(array: Any, digits: int = 5) -> Any:
    return np.round(np.asarray(array, dtype=float), digits).tolist()


class WorldSampler:
    """A tick-log listener sampling the world of a run on `robot` (a resource with `arms` and `link`)."""

    def __init__(
        self,
        robot: Any,
        sinks: list[Callable[[dict[str, Any]], None]],
        *,
        period: float = 0.1,
        cell: Workcell | None = None,
    ) -> None:
        self.robot = robot
        self.cell = cell or workcell()
        self.sinks = sinks
        self.period = period
        self._last_t = -np.inf
        self._last_truth_t = -np.inf
        self._truth: list[dict[str, Any]] | None = None
        self._next_entry = 0  # the simulator's log index to ask from
        self.broken = False

    def __call__(self, record: dict[str, Any]) -> None:
        if record["type"] not in ("tick", "halt", "end") or self.broken:
            return
        try:
            self._sample(record)
        except Exception as error:  # noqa: BLE001 (the view is an aid: it never stops the run it watches)
            self.broken = True
            LOG.warning(
                "monitor: the 3D view stops, its sampling failed: %s: %s", type(error).__name__, error
            )

    def _sample(self, record: dict[str, Any]) -> None:
        t = float(record["t"])
        perceived = [key for key in PERCEPTION_KEYS if key in (record.get("bb") or {})]
        if not perceived and t - self._last_t < self.period and record["type"] == "tick":
            return
        self._last_t = t
        sample: dict[str, Any] = {"type": "world", "n": record["n"], "t": t, "tools": self._tools()}
        storage = py_trees.blackboard.Blackboard.storage
        if "/cloud" in perceived and storage.get("/cloud") is not None:
            sample["cloud"] = self._cloud(storage["/cloud"], storage.get("/board"))
        if "/blocks" in perceived:
            sample["blocks"] = believed_blocks(storage.get("/blocks"))
        if self.robot.truth is not None and (t - self._last_truth_t >= TRUTH_PERIOD or perceived):
            self._last_truth_t = t
            sample["truth"], faults = self._ask_truth(t)
            if faults:
                sample["faults"] = faults
        for sink in self.sinks:
            sink(sample)

    def _tools(self) -> dict[str, list[list[list[float]]]]:
        tools = {}
        for name, arm in self.robot.arms.items():
            try:
                q = arm.measured_js.position
            except PegbtError:  # no state yet: the arm is left out of this sample
                continue
            if len(q) != 6:
                continue
            segments = tool_segments(q, self.cell.arm_to_board(name), self.cell.tool)
            tools[name] = [_rounded(start) for start, _ in segments] + [_rounded(segments[-1][1])]
        return tools

    def _cloud(self, points: Any, board: Any) -> list[float]:
        board_from_camera = getattr(board, "board_from_camera", None)
        if board_from_camera is None:
            board_from_camera = self.cell.camera.board_from_camera
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        step = max(1, len(points) // CLOUD_POINTS)
        return np.round(apply_rigid(board_from_camera, points[::step]), 4).ravel().tolist()

    def _ask_truth(self, t: float) -> tuple[list[dict[str, Any]] | None, list[dict[str, Any]]]:
        """The simulator's blocks now, and the faults it injected since the last question (run time, detail)."""
        try:
            truth = ask_truth(self.robot.link, since=self._next_entry, timeout=1.0)
        except PegbtError:
            return self._truth, []
        self._next_entry = truth.next
        self._truth = [
            {"block": block.get("block"), "state": block.get("state"), "pose": _rounded(block["pose"])}
            for block in truth.blocks
        ]
        offset = t - truth.time  # simulator seconds to run seconds (the tick started at t)
        faults = [
            {"t": round(entry["time"] + offset, 4), "detail": str(entry.get("detail", ""))}
            for entry in truth.log
            if entry.get("kind") == "fault"
        ]
        return self._truth, faults


def believed_blocks(blocks: Any) -> list[dict[str, Any]]:
    """Perception's blocks (`BlockEstimate`s) as position, yaw, peg and whether the pose is trusted."""
    found = []
    for block in blocks or ():
        position = getattr(block, "position", None)
        if position is None:
            continue
        found.append(
            {
                "position": _rounded(position),
                "yaw": round(float(block.yaw), 5),
                "peg": block.peg,
                "ok": bool(block.ok),
            }
        )
    return found


class WorldLogWriter:
    """Writes world samples as JSON lines beside the tick log, for `pegbt monitor LOG`."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._file: IO[str] = path.open("w", encoding="utf-8")
        self._file.write(json.dumps(scene()) + "\n")

    def __call__(self, sample: dict[str, Any]) -> None:
        self._file.write(json.dumps(sample, separators=(",", ":")) + "\n")
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def read_world_log(path: Path) -> list[dict[str, Any]]:
    """The scene and samples of a world sidecar; a `PegbtError` naming the line of a corrupt one."""
    messages = []
    with path.open(encoding="utf-8") as file:
        for number, line in enumerate(file, start=1):
            try:
                message = json.loads(line)
            except json.JSONDecodeError as error:
                raise PegbtError(f"corrupt world record: {error.msg}", file=path, line=number) from None
            if not isinstance(message, dict) or message.get("type") not in ("scene", "world"):
                raise PegbtError("not a world record", file=path, line=number, field="type")
            messages.append(message)
    return messages
