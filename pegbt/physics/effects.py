"""Cable effects between a commanded joint and the physical joint, as plain data.

An `Effect` names one physical phenomenon on one joint with its parameters, in the same form as the
sim-to-real report (`{"effect": "coupling", "joint": "q5", "params": {"source": "q6", "k": 0.21}}`):

- `offset` {value}: physical = command + value (rad or m).
- `scale` {value}: physical = value × command.
- `coupling` {source, k}: physical += k × the source joint's command (cables routed past each other).
- `backlash` {half_width}: play; the output stays until the input has moved half_width past it.
- `lag` {tau}: first-order response with time constant tau (s).
- `delay` {seconds}: pure transport delay of the command.
- `hysteresis` {source, half_width, k}: physical += k × (play(x, half_width) − x), x the source's
  command: play in one joint's drive that shows, scaled by k, in this joint. With source = the joint
  itself, x is the joint's static target (the input its backlash sees) and k ≠ 1 is play of which only
  part reaches the joint (k = 1 is backlash). Found on the real dVRK wrist, where q6's cable play moves
  q5 about as much as q6.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pegbt.errors import PegbtError
from pegbt.psm import JOINT_NAMES

# Parameters each effect kind takes; `source` is a joint name, the rest are floats.
EFFECT_KINDS: dict[str, tuple[str, ...]] = {
    "offset": ("value",),
    "scale": ("value",),
    "coupling": ("source", "k"),
    "backlash": ("half_width",),
    "lag": ("tau",),
    "delay": ("seconds",),
    "hysteresis": ("source", "half_width", "k"),
}

_NON_NEGATIVE = {
    ("backlash", "half_width"),
    ("lag", "tau"),
    ("delay", "seconds"),
    ("hysteresis", "half_width"),
}


def joint_index(name: str | int) -> int:
    """0-based index of a joint given as `q1`..`q6` or as an index."""
    if isinstance(name, int) and 0 <= name < len(JOINT_NAMES):
        return name
    if isinstance(name, str) and name in JOINT_NAMES:
        return JOINT_NAMES.index(name)
    raise PegbtError(f"unknown joint {name!r}; expected one of {', '.join(JOINT_NAMES)}", field="joint")


@dataclass(frozen=True)
class Effect:
    """One cable effect on one joint."""

    effect: str
    joint: str
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.effect not in EFFECT_KINDS:
            raise PegbtError(
                f"unknown effect {self.effect!r}; expected one of {', '.join(EFFECT_KINDS)}", field="effect"
            )
        joint_index(self.joint)
        expected = set(EFFECT_KINDS[self.effect])
        if set(self.params) != expected:
            raise PegbtError(
                f"{self.effect} on {self.joint} takes parameters {sorted(expected)}, got {sorted(self.params)}",
                field="params",
            )
        for name, value in self.params.items():
            if name == "source":
                if self.effect == "coupling" and joint_index(value) == joint_index(self.joint):
                    raise PegbtError(f"coupling on {self.joint} cannot take itself as source", field="source")
                continue
            if not isinstance(value, (int, float)) or value != value or abs(value) == float("inf"):
                raise PegbtError(f"{self.effect}.{name} on {self.joint} must be a finite number", field=name)
            if (self.effect, name) in _NON_NEGATIVE and value < 0:
                raise PegbtError(
                    f"{self.effect}.{name} on {self.joint} must be >= 0, got {value}", field=name
                )

    @property
    def index(self) -> int:
        return joint_index(self.joint)

    @property
    def slot(self) -> tuple[str, str, str, float]:
        """What the effect occupies in a model: one offset, scale, backlash, lag, delay per joint, one
        coupling per source, and one hysteresis per source and play width (several widths from the same
        drive add up to a hysteresis loop of any shape, as in a Prandtl–Ishlinskii operator)."""
        width = float(self.params["half_width"]) if self.effect == "hysteresis" else 0.0
        return (self.effect, self.joint, str(self.params.get("source", "")), width)

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "joint": self.joint, "params": dict(self.params)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Effect":
        """Read an effect from its report / preset form; extra keys (ci, text, ...) are ignored."""
        if not isinstance(data, Mapping):
            raise PegbtError(f"an effect entry is an object with effect, joint and params; got {data!r}")
        params = data.get("params", {})
        if not isinstance(params, Mapping):
            raise PegbtError(f"params is an object of parameter values; got {params!r}", field="params")
        try:
            return cls(str(data["effect"]), str(data["joint"]), dict(params))
        except KeyError as missing:
            raise PegbtError(f"effect entry lacks {missing.args[0]!r}", field=str(missing.args[0])) from None
