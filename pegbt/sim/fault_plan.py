"""Fault injection by configuration: message loss and latency and an endpoint crash (the endpoint's),
slips and missed grasps (the world's, `WorldFaults`) and depth-noise bursts (the camera's, `CameraFaults`).

Loss and latency are drawn from a seeded generator keyed by the message itself (its key and stamp,
or a command's sequence number), so a lockstep run with the same seed injects the same faults; the
world and camera draw theirs from the same seed. Times are simulated seconds since the start. Every
injected fault is written to the simulator's log with its time.

    seed: 7
    loss:    {probability: 0.05, topics: [servo_jp, measured_js]}
    latency: {seconds: 0.02, jitter: 0.005, topics: [setpoint_js]}
    crash:   {at: 30.0}
    world:   {slips: [{time: 12.0, arm: PSM1}], miss_attempts: [0], slip_rate: 0.0, miss_probability: 0.0}
    camera:  {bursts: [{start: 5.0, duration: 1.0, sigma: 0.003}], burst_probability: 0.0}
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import yaml

from pegbt.errors import PegbtError
from pegbt.sim.faults import CameraFaults, WorldFaults

# Streams lose and lag messages by default; events (operating_state, error) and move commands only if listed.
STREAM_TOPICS = ("measured_js", "setpoint_js", "fiducial_js", "measured_cp", "servo_jp")
T = TypeVar("T")


@dataclass(frozen=True)
class FaultPlan:
    seed: int = 0
    loss_probability: float = 0.0
    loss_topics: tuple[str, ...] = STREAM_TOPICS
    latency: float = 0.0
    jitter: float = 0.0
    latency_topics: tuple[str, ...] = STREAM_TOPICS
    crash_at: float | None = None
    world: WorldFaults = field(default_factory=WorldFaults)
    camera: CameraFaults = field(default_factory=CameraFaults)

    @classmethod
    def load(cls, path: Path) -> "FaultPlan":
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as error:
            raise PegbtError(f"cannot read fault plan: {error}", file=path) from None
        try:
            node = yaml.compose(text, Loader=yaml.SafeLoader)
        except yaml.YAMLError as error:
            mark = getattr(error, "problem_mark", None)
            line, column = (mark.line + 1, mark.column + 1) if mark else (None, None)
            raise PegbtError(f"not valid YAML: {getattr(error, 'problem', error)}", file=path, line=line, column=column) from None
        return _PlanReader(path).plan(node)


class _PlanReader:
    """Reads a fault plan from a YAML node tree, so each error names its line, column and field."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, node: yaml.Node, field_name: str, message: str) -> PegbtError:
        return PegbtError(message, file=self.path, line=node.start_mark.line + 1, column=node.start_mark.column + 1, field=field_name)

    def mapping(self, node: yaml.Node | None, field_name: str, allowed: tuple[str, ...]) -> dict[str, yaml.Node]:
        if node is None:
            return {}
        if not isinstance(node, yaml.MappingNode):
            raise self.fail(node, field_name, "expected a mapping")
        items = {}
        for key, value in node.value:
            if key.value not in allowed:
                raise self.fail(key, f"{field_name}.{key.value}".lstrip("."), f"unknown field; expected one of {', '.join(allowed)}")
            items[key.value] = value
        return items

    def number(self, node: yaml.Node, field_name: str, low: float = 0.0, high: float = float("inf")) -> float:
        try:
            value = float(yaml.safe_load(yaml.serialize(node)))
        except (TypeError, ValueError):
            raise self.fail(node, field_name, "expected a number") from None
        if not low <= value <= high:
            raise self.fail(node, field_name, f"expected a number in [{low}, {high}], got {value}")
        return value

    def topics(self, node: yaml.Node | None, field_name: str) -> tuple[str, ...]:
        if node is None:
            return STREAM_TOPICS
        if not isinstance(node, yaml.SequenceNode) or not all(isinstance(item, yaml.ScalarNode) for item in node.value):
            raise self.fail(node, field_name, "expected a list of topic names")
        return tuple(item.value.strip("/") for item in node.value)

    def plan(self, root: yaml.Node | None) -> FaultPlan:
        top = self.mapping(root, "", ("seed", "loss", "latency", "crash", "world", "camera"))
        loss = self.mapping(top.get("loss"), "loss", ("probability", "topics"))
        latency = self.mapping(top.get("latency"), "latency", ("seconds", "jitter", "topics"))
        crash = self.mapping(top.get("crash"), "crash", ("at",))
        return FaultPlan(
            seed=int(self.number(top["seed"], "seed")) if "seed" in top else 0,
            loss_probability=self.number(loss["probability"], "loss.probability", high=1.0) if "probability" in loss else 0.0,
            loss_topics=self.topics(loss.get("topics"), "loss.topics"),
            latency=self.number(latency["seconds"], "latency.seconds") if "seconds" in latency else 0.0,
            jitter=self.number(latency["jitter"], "latency.jitter") if "jitter" in latency else 0.0,
            latency_topics=self.topics(latency.get("topics"), "latency.topics"),
            crash_at=self.number(crash["at"], "crash.at") if "at" in crash else None,
            world=self.section(top.get("world"), "world", WorldFaults.from_mapping, WorldFaults()),
            camera=self.section(top.get("camera"), "camera", CameraFaults.from_mapping, CameraFaults()),
        )

    def section(self, node: yaml.Node | None, name: str, read: Callable[..., T], default: T) -> T:
        """A world or camera section, read by that part's own `from_mapping`; errors point at the field."""
        if node is None:
            return default
        data = yaml.safe_load(yaml.serialize(node))
        if not isinstance(data, dict):
            raise self.fail(node, name, "expected a mapping")
        try:
            return read(data, self.path, prefix=name)
        except PegbtError as error:
            raise self.fail(_locate(node, (error.field or name).split(".")[1:]), error.field or name, error.message) from None


def _locate(node: yaml.Node, path: list[str]) -> yaml.Node:
    """The deepest node along a dotted field path such as `slips[0].time` (as far as it exists)."""
    for part in path:
        key, _, index = part.partition("[")
        children = {k.value: v for k, v in node.value} if isinstance(node, yaml.MappingNode) else {}
        if key not in children:
            return node
        node = children[key]
        index = index.rstrip("]")
        if index.isdigit() and isinstance(node, yaml.SequenceNode) and int(index) < len(node.value):
            node = node.value[int(index)]
    return node


def _matches(key: str, topics: tuple[str, ...]) -> bool:
    return any(key == topic or key.endswith("/" + topic) for topic in topics)


def _uniform(seed: int, *parts: object) -> float:
    """A uniform number in [0, 1) fixed by the seed and the message's identity (not by call order)."""
    digest = hashlib.blake2b(f"{seed}|{'|'.join(map(str, parts))}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") / 2**64


class FaultInjector:
    """Decides, per message, whether it is lost and how late it is, and when the endpoint crashes."""

    def __init__(self, plan: FaultPlan) -> None:
        self.plan = plan
        self.crashed = False

    def affects(self, key: str) -> bool:
        """Whether loss or latency may act on the messages of `key`."""
        plan = self.plan
        lossy = plan.loss_probability > 0 and _matches(key, plan.loss_topics)
        return lossy or (plan.latency > 0 or plan.jitter > 0) and _matches(key, plan.latency_topics)

    def lost(self, key: str, identity: str) -> bool:
        plan = self.plan
        return plan.loss_probability > 0 and _matches(key, plan.loss_topics) and _uniform(plan.seed, "loss", key, identity) < plan.loss_probability

    def delay(self, key: str, identity: str) -> float:
        plan = self.plan
        if plan.latency <= 0 and plan.jitter <= 0 or not _matches(key, plan.latency_topics):
            return 0.0
        return plan.latency + plan.jitter * _uniform(plan.seed, "latency", key, identity)

    def crash_due(self, elapsed: float) -> bool:
        if self.plan.crash_at is not None and not self.crashed and elapsed >= self.plan.crash_at - 1e-9:
            self.crashed = True
        return self.crashed
