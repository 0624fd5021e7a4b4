"""Faults the world and its camera can inject, by configuration: slips from the jaw, grasps that miss,
bursts of depth noise.

Each is either scheduled (a slip at a given time, the n-th grasp attempt missing) or drawn with a
probability from the world's seeded generator, so a faulty run is as reproducible as a clean one.
Every injected fault is logged as a `fault` event before its consequence.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pegbt.errors import PegbtError
from pegbt.workcell import ARMS


@dataclass(frozen=True)
class SlipAt:
    """At `time` (s), the block held by `arm` (any arm holding one, if None) slips from the jaw."""

    time: float
    arm: str | None = None


@dataclass(frozen=True)
class WorldFaults:
    slips: tuple[SlipAt, ...] = ()
    slip_rate: float = 0.0  # per second of holding a block
    miss_attempts: frozenset[int] = field(default_factory=frozenset)  # grasp attempts (from 0) that miss
    miss_probability: float = 0.0  # of any grasp that would have held

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], source: Path | str | None = None, prefix: str = "faults") -> WorldFaults:
        """Faults from a configuration mapping (keys as the fields; slips as [{time, arm}]); errors name
        the field under `prefix`."""

        def fail(name: str, message: str) -> PegbtError:
            return PegbtError(message, file=source, field=f"{prefix}.{name}")

        def probability(name: str, upper: float) -> float:
            value = data.get(name, 0.0)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= upper:
                raise fail(name, f"expected a number in [0, {upper:g}], got {value!r}")
            return float(value)

        unknown = set(data) - {"slips", "slip_rate", "miss_attempts", "miss_probability"}
        if unknown:
            raise fail(sorted(unknown)[0], "unknown fault setting")
        slips = []
        for index, entry in enumerate(data.get("slips", [])):
            entry = entry if isinstance(entry, dict) else {}
            time, arm = entry.get("time"), entry.get("arm")
            if isinstance(time, bool) or not isinstance(time, (int, float)) or not math.isfinite(time):
                raise fail(f"slips[{index}].time", f"expected a time in seconds, got {time!r}")
            if arm is not None and arm not in ARMS:
                raise fail(f"slips[{index}].arm", f"expected one of {', '.join(ARMS)}, got {arm!r}")
            slips.append(SlipAt(float(time), arm))
        attempts = data.get("miss_attempts", [])
        if not isinstance(attempts, list) or not all(isinstance(a, int) and a >= 0 for a in attempts):
            raise fail("miss_attempts", f"expected a list of attempt numbers (0, 1, ...), got {attempts!r}")
        return cls(
            slips=tuple(sorted(slips, key=lambda slip: slip.time)),
            slip_rate=probability("slip_rate", math.inf),
            miss_attempts=frozenset(attempts),
            miss_probability=probability("miss_probability", 1.0),
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
    def from_mapping(cls, data: Mapping[str, Any], source: Path | str | None = None, prefix: str = "camera_faults") -> CameraFaults:
        """Faults from configuration: `bursts: [{start, duration, sigma?, outliers?}]`, `burst_probability`;
        errors name the field under `prefix`."""
        unknown = set(data) - {"bursts", "burst_probability"}
        if unknown:
            raise PegbtError("unknown camera fault setting", file=source, field=f"{prefix}.{sorted(unknown)[0]}")
        bursts = []
        for index, entry in enumerate(data.get("bursts", [])):
            field = f"{prefix}.bursts[{index}]"
            if not isinstance(entry, dict) or not {"start", "duration"} <= set(entry) <= {"start", "duration", "sigma", "outliers"}:
                raise PegbtError("expected {start, duration, sigma?, outliers?}", file=source, field=field)
            values = {key: entry[key] for key in entry}
            if not all(_is_number(value) and value >= 0 for value in values.values()) or values.get("outliers", 0) > 1:
                raise PegbtError(f"expected non-negative numbers (outliers at most 1), got {entry!r}", file=source, field=field)
            bursts.append(NoiseBurst(**{key: float(value) for key, value in values.items()}))
        probability = data.get("burst_probability", 0.0)
        if not _is_number(probability) or not 0.0 <= probability <= 1.0:
            raise PegbtError(f"expected a number in [0, 1], got {probability!r}", file=source, field=f"{prefix}.burst_probability")
        return cls(bursts=tuple(bursts), burst_probability=float(probability))


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
