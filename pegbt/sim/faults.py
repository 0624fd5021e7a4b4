"""Faults the world and its camera can inject, by configuration: slips from the jaw, grasps that miss,
bursts of depth noise.

Each is either scheduled (a slip at a given time, or a given time after the n-th world event of a kind:
a slip 0.3 s after PSM1 lifts its first block keeps falling in that carry whatever the path before it
took; the n-th grasp attempt missing) or drawn with a probability from the world's seeded generator, so a
faulty run is as reproducible as a clean one.
Every injected fault is logged as a `fault` event before its consequence.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pegbt.psm import ARMS
from pegbt.sim.events import EVENT_KINDS, Event
from pegbt.yamlfile import Located

DAY = 86_400.0  # s: the latest a fault may be planned (a trial lasts about a minute)
MAX_SIGMA = 0.05  # m of depth noise: five times a block's size, a camera that sees nothing
MAX_RATE = 100.0  # slips per second of holding: one per 10 ms tick


@dataclass(frozen=True)
class EventMark:
    """The `nth` (from 1) world event of `kind` in a run, counting only `arm`'s if given (a two-arm event,
    "PSM1+PSM2", counts for each)."""

    kind: str
    nth: int = 1
    arm: str | None = None

    def matches(self, event: Event) -> bool:
        return event.kind == self.kind and (self.arm is None or self.arm in (event.arm or "").split("+"))


@dataclass(frozen=True)
class SlipAt:
    """At `time` (s; after the event `after` marks, if given, else since the start), the block held by
    `arm` (any arm holding one, if None) slips from the jaw."""

    time: float
    arm: str | None = None
    after: EventMark | None = None


@dataclass(frozen=True)
class WorldFaults:
    slips: tuple[SlipAt, ...] = ()
    slip_rate: float = 0.0  # per second of holding a block
    miss_attempts: frozenset[int] = field(default_factory=frozenset)  # grasp attempts (from 0) that miss
    miss_probability: float = 0.0  # of any grasp that would have held

    @classmethod
    def read(cls, section: Located) -> WorldFaults:
        """Faults from a fault plan's `world:` mapping (keys as the fields; slips as
        [{time, arm?, after?: {event, nth?, arm?}}])."""
        entries = section.mapping(("slips", "slip_rate", "miss_attempts", "miss_probability"))
        slips = [_slip(entry) for entry in entries["slips"].sequence()] if "slips" in entries else []
        attempts = (
            [item.integer(low=0) for item in entries["miss_attempts"].sequence()]
            if "miss_attempts" in entries
            else []
        )
        return cls(
            slips=tuple(sorted(slips, key=lambda slip: (slip.after is not None, slip.time))),
            slip_rate=section.number_or("slip_rate", 0.0, low=0.0, high=MAX_RATE),
            miss_attempts=frozenset(attempts),
            miss_probability=section.number_or("miss_probability", 0.0, low=0.0, high=1.0),
        )


def _slip(entry: Located) -> SlipAt:
    entry.mapping(("time", "arm", "after"))
    arm, after = entry.get("arm"), entry.get("after")
    return SlipAt(
        entry["time"].number(low=0.0, high=DAY),
        None if arm is None else arm.choice(ARMS),
        None if after is None else _mark(after),
    )


def _mark(entry: Located) -> EventMark:
    entry.mapping(("event", "nth", "arm"))
    nth, arm = entry.get("nth"), entry.get("arm")
    return EventMark(
        entry["event"].choice(EVENT_KINDS),
        1 if nth is None else nth.integer(low=1),
        None if arm is None else arm.choice(ARMS),
    )


@dataclass(frozen=True)
class NoiseBurst:
    """From `start` for `duration` seconds, depth noise of `sigma` and a fraction of wild points."""

    start: float
    duration: float
    sigma: float = 0.003
    outliers: float = 0.05  # fraction of points thrown anywhere between 0.8 and 1.2 × their depth

    def active(self, time: float) -> bool:
        return self.start <= time < self.start + self.duration


@dataclass(frozen=True)
class CameraFaults:
    bursts: tuple[NoiseBurst, ...] = ()
    burst_probability: float = 0.0  # chance that any one capture is a burst
    random_burst: NoiseBurst = NoiseBurst(0.0, 0.0)  # its sigma and outliers apply to random bursts

    @classmethod
    def read(cls, section: Located) -> CameraFaults:
        """Faults from a fault plan's `camera:` mapping: `bursts: [{start, duration, sigma?, outliers?}]`,
        `burst_probability`."""
        entries = section.mapping(("bursts", "burst_probability"))
        bursts = tuple(_burst(entry) for entry in entries["bursts"].sequence()) if "bursts" in entries else ()
        return cls(
            bursts=bursts, burst_probability=section.number_or("burst_probability", 0.0, low=0.0, high=1.0)
        )


def _burst(entry: Located) -> NoiseBurst:
    entry.mapping(("start", "duration", "sigma", "outliers"))
    default = NoiseBurst(0.0, 0.0)
    return NoiseBurst(
        start=entry["start"].number(low=0.0, high=DAY),
        duration=entry["duration"].number(low=0.0, high=DAY),
        sigma=entry.number_or("sigma", default.sigma, low=0.0, high=MAX_SIGMA),
        outliers=entry.number_or("outliers", default.outliers, low=0.0, high=1.0),
    )
