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
from dataclasses import dataclass, field
from pathlib import Path

from pegbt.sim.faults import DAY, CameraFaults, WorldFaults
from pegbt.yamlfile import Located, read_yaml_file

# Streams lose and lag messages by default; events (operating_state, error) and move commands only if listed.
MAX_LATENCY = 10.0  # s: a message later than this is lost, which is the `loss` fault
STREAM_TOPICS = ("measured_js", "setpoint_js", "fiducial_js", "measured_cp", "servo_jp")


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
    def load(cls, path: Path) -> FaultPlan:
        """The plan in a YAML file (an empty file: no faults); errors name file, line, column and field."""
        document = read_yaml_file(path)
        return cls() if document is None else cls.read(document)

    @classmethod
    def read(cls, document: Located) -> FaultPlan:
        document.mapping(("seed", "loss", "latency", "crash", "world", "camera"))
        loss = document.section("loss", ("probability", "topics"))
        latency = document.section("latency", ("seconds", "jitter", "topics"))
        crash_at = document.section("crash", ("at",)).get("at")
        seed = document.get("seed")
        return FaultPlan(
            seed=0 if seed is None else seed.integer(low=0, high=2**32 - 1),
            loss_probability=loss.number_or("probability", 0.0, low=0.0, high=1.0),
            loss_topics=_topics(loss),
            latency=latency.number_or("seconds", 0.0, low=0.0, high=MAX_LATENCY),
            jitter=latency.number_or("jitter", 0.0, low=0.0, high=MAX_LATENCY),
            latency_topics=_topics(latency),
            crash_at=None if crash_at is None else crash_at.number(low=0.0, high=DAY),
            world=WorldFaults.read(document.section("world")),
            camera=CameraFaults.read(document.section("camera")),
        )


def _topics(section: Located) -> tuple[str, ...]:
    """The section's `topics` (names with or without slashes), or the streams when it names none."""
    topics = section.get("topics")
    return STREAM_TOPICS if topics is None else tuple(item.text().strip("/") for item in topics.sequence())


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
        return (
            plan.loss_probability > 0
            and _matches(key, plan.loss_topics)
            and _uniform(plan.seed, "loss", key, identity) < plan.loss_probability
        )

    def delay(self, key: str, identity: str) -> float:
        plan = self.plan
        if plan.latency <= 0 and plan.jitter <= 0 or not _matches(key, plan.latency_topics):
            return 0.0
        return plan.latency + plan.jitter * _uniform(plan.seed, "latency", key, identity)

    def crash_due(self, elapsed: float) -> bool:
        if self.plan.crash_at is not None and not self.crashed and elapsed >= self.plan.crash_at - 1e-9:
            self.crashed = True
        return self.crashed
